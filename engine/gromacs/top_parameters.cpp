#include "engine/gromacs/top_parameters.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <tuple>

namespace vimd::top {

namespace {

std::pair<std::string, std::string> ordered(std::string a, std::string b) {
  if (b < a) std::swap(a, b);
  return {std::move(a), std::move(b)};
}

// Redefinitions with identical values are harmless; different values are an error (grompp
// treats them as a warning, which is fatal without -maxwarn).
template <class Key, class Params>
void define_parameters(std::map<Key, std::pair<Params, Where>>& table, const Key& key, const Params& params,
                       const Where& where, const std::string& what) {
  const auto [it, inserted] = table.try_emplace(key, params, where);
  if (!inserted && it->second.first != params)
    fail(where, what + " redefined with different parameters (first defined at " + it->second.second.str() + ")");
}

// grompp's push_bondtype for dihedrals: a line with the atoms of an earlier one (either
// direction) and the same parameters is dropped; with other parameters it is an error (grompp's
// warning, fatal without -maxwarn), except for type 9, where lines for the same atoms next to
// each other add terms.
void add_dihedraltype(std::vector<DihedralType>& table, DihedralType type, bool allow_repeat, const Fields& f) {
  const bool continues_block = allow_repeat && table.size() > 1 && table[table.size() - 2].atoms == type.atoms;
  std::array<std::string, 4> reversed{type.atoms[3], type.atoms[2], type.atoms[1], type.atoms[0]};
  bool add = true;
  for (const DihedralType& old : table) {
    if (old.atoms != type.atoms && old.atoms != reversed) continue;
    const bool identical = old.params == type.params && old.perturbed == type.perturbed;
    if (!allow_repeat || identical) add = false;
    if (identical) continue;
    if (!allow_repeat)
      f.error("[ dihedraltypes ] " + old.atoms[0] + " " + old.atoms[1] + " " + old.atoms[2] + " " + old.atoms[3] +
              " redefined with different parameters (first defined at " + old.where.str() +
              "); use function 9 for several terms, on consecutive lines");
    if (!continues_block)
      f.error("a second block of [ dihedraltypes ] function 9 lines for " + type.atoms[0] + " " + type.atoms[1] + " " +
              type.atoms[2] + " " + type.atoms[3] + " (the first at " + old.where.str() +
              "): grompp only combines consecutive lines");
  }
  if (!add) return;
  DihedralType back = type;
  back.atoms = reversed;
  table.push_back(std::move(type));
  table.push_back(std::move(back));
}

}  // namespace

std::optional<DihedralFunction> dihedral_function(long func) {
  switch (func) {
    case 1:
    case 9: return DihedralFunction{1, 3, 2, "phi_s k multiplicity"};
    case 2: return DihedralFunction{2, 2, 2, "xi0 k"};
    case 3: return DihedralFunction{3, 6, 6, "C0 C1 C2 C3 C4 C5"};
    case 4: return DihedralFunction{4, 3, 2, "phi_s k multiplicity"};
    case 5: return DihedralFunction{5, 4, 4, "F1 F2 F3 F4"};
    default: return std::nullopt;
  }
}

bool dihedral_function_unsupported(long func) { return func == 8 || func == 10 || func == 11; }

std::pair<std::vector<double>, bool> dihedral_parameters(const Fields& f, std::size_t first,
                                                         const DihedralFunction& function) {
  auto values = f.numbers_from(first, "parameter");
  if (values.empty()) return {};
  if (values.size() != function.n_a && values.size() != function.n_a + function.n_b)
    f.error("expected " + std::to_string(function.n_a) + " parameters (" + function.layout + "), or " +
            std::to_string(function.n_a + function.n_b) + " with the B state, found " + std::to_string(values.size()));
  const bool perturbed = values.size() > function.n_a &&
                         !std::equal(values.begin() + function.n_a, values.end(), values.begin());
  values.resize(function.n_a);
  if (function.table == 1 || function.table == 4) {
    if (values[2] != std::round(values[2])) f.error("multiplicity " + format_number(values[2]) + " is not an integer");
  }
  return {values, perturbed};
}

void ForceFieldParameters::defaults(const Fields& f) {
  if (comb_rule_) f.error("second [ defaults ] line (the first is at " + defaults_where_.str() + ")");
  f.require(2, "nbfunc comb-rule [gen-pairs fudgeLJ fudgeQQ]");
  if (f.integer(0, "nbfunc") != 1)
    f.error("nbfunc " + f[0] + " is not supported: vimd computes Lennard-Jones only (nbfunc 1)");
  const long rule = f.integer(1, "comb-rule");
  if (rule < 1 || rule > 3) f.error("comb-rule " + f[1] + " is not one of 1, 2, 3");
  comb_rule_ = static_cast<int>(rule);
  defaults_where_ = f.where();
  // As grompp: gen-pairs is yes when the word starts with Y or y; the fudges default to 1.
  if (f.size() > 2) gen_pairs_ = std::toupper(static_cast<unsigned char>(f[2][0])) == 'Y';
  if (f.size() > 3) fudge_lj_ = f.number(3, "fudgeLJ");
  if (f.size() > 4) fudge_qq_ = f.number(4, "fudgeQQ");
}

// GROMACS allows the bonded type and the atomic number columns to be absent; the position of
// the one-letter particle type (A, S, V, D, …) tells which layout a line has.
void ForceFieldParameters::atomtype(const Fields& f) {
  f.require(6, "name [bond_type] [at.num] mass charge ptype V W");
  const auto is_ptype = [&](std::size_t k) {
    return f[k].size() == 1 && std::isalpha(static_cast<unsigned char>(f[k][0]));
  };
  std::size_t p = 0;
  bool has_bonded_name = false;
  if (is_ptype(5)) {
    p = 5;
    has_bonded_name = true;
  } else if (is_ptype(3)) {
    p = 3;
  } else if (is_ptype(4)) {
    p = 4;
    has_bonded_name = std::isalpha(static_cast<unsigned char>(f[1][0])) != 0;
  } else {
    f.error("cannot find the particle-type column (a single letter A, S, V or D) in [ atomtypes ]");
  }
  f.require(p + 3, "name [bond_type] [at.num] mass charge ptype V W");
  AtomType type{f[0], has_bonded_name ? f[1] : f[0], f.number(p - 2, "mass"), f.number(p - 1, "charge"),
                static_cast<char>(std::toupper(static_cast<unsigned char>(f[p][0]))), f.number(p + 1, "V"),
                f.number(p + 2, "W"), f.where()};
  if (std::string("ANSBVD").find(type.ptype) == std::string::npos)
    f.error("unknown particle type '" + f[p] + "' (expected A, N, S, B, V or D)");
  if (type.w < 0 || (*comb_rule_ == 1 && type.v < 0))
    f.error(std::string(*comb_rule_ == 1 ? "c6 and c12" : "epsilon") + " must not be negative");
  const auto [it, inserted] = atomtype_index_.try_emplace(type.name, static_cast<int>(atomtypes_.size()));
  if (inserted) {
    bonded_names_.insert(type.bonded_name);
    atomtypes_.push_back(type);
    return;
  }
  const AtomType& old = atomtypes_[it->second];
  if (old.bonded_name != type.bonded_name || old.mass != type.mass || old.charge != type.charge ||
      old.ptype != type.ptype || old.v != type.v || old.w != type.w)
    f.error("atom type '" + type.name + "' redefined with different parameters (first defined at " +
            old.where.str() + ")");
}

const AtomType& ForceFieldParameters::atomtype_named(const Fields& f, std::size_t k) const {
  const auto it = atomtype_index_.find(f[k]);
  if (it == atomtype_index_.end()) f.error("unknown atom type '" + f[k] + "' (not defined in [ atomtypes ])");
  return atomtypes_[it->second];
}

void ForceFieldParameters::nonbond_params(const Fields& f) {
  f.require(5, "type_i type_j func V W");
  if (f.integer(2, "func") != 1) f.error("[ nonbond_params ] function type " + f[2] + " is not supported (only 1, LJ)");
  const auto& a = atomtype_named(f, 0);
  const auto& b = atomtype_named(f, 1);
  define_parameters(nonbond_params_, ordered(a.name, b.name), std::pair{f.number(3, "V"), f.number(4, "W")},
                    f.where(), "[ nonbond_params ] " + a.name + " " + b.name);
}

void ForceFieldParameters::bondtype(const Fields& f) {
  f.require(3, "type_i type_j func parameters");
  // Other bond functions cannot be computed; bonds that use them are refused where they occur.
  if (f.integer(2, "func") != 1) return;
  f.require(5, "type_i type_j 1 b0 kb");
  define_parameters(bondtypes_, ordered(f[0], f[1]), std::pair{f.number(3, "b0"), f.number(4, "kb")}, f.where(),
                    "[ bondtypes ] " + f[0] + " " + f[1]);
}

void ForceFieldParameters::constrainttype(const Fields& f) {
  f.require(4, "type_i type_j func b0");
  const long func = f.integer(2, "func");
  if (func != 1 && func != 2) f.error("constraint function type " + f[2] + " does not exist (1 or 2)");
  define_parameters(constrainttypes_, std::pair{static_cast<int>(func), ordered(f[0], f[1])}, f.number(3, "b0"),
                    f.where(), "[ constrainttypes ] " + f[0] + " " + f[1]);
}

void ForceFieldParameters::angletype(const Fields& f) {
  f.require(4, "type_i type_j type_k func parameters");
  if (f.integer(3, "func") != 1) return;  // as for bondtypes
  f.require(6, "type_i type_j type_k 1 theta0 k");
  // i-j-k and k-j-i are the same angle.
  auto key = f[0] <= f[2] ? std::array{f[0], f[1], f[2]} : std::array{f[2], f[1], f[0]};
  define_parameters(angletypes_, key, std::pair{f.number(4, "theta0"), f.number(5, "k")}, f.where(),
                    "[ angletypes ] " + f[0] + " " + f[1] + " " + f[2]);
}

// Keyed by (nonbonded) atom type names, as grompp's pair parameters.
void ForceFieldParameters::pairtype(const Fields& f) {
  f.require(3, "type_i type_j func parameters");
  if (f.integer(2, "func") != 1) return;  // function 2 pairs are refused where they occur
  f.require(5, "type_i type_j 1 V W");
  const auto& a = atomtype_named(f, 0);
  const auto& b = atomtype_named(f, 1);
  define_parameters(pairtypes_, ordered(a.name, b.name), std::pair{f.number(3, "V"), f.number(4, "W")}, f.where(),
                    "[ pairtypes ] " + a.name + " " + b.name);
}

// Either "ai aj func params" (two bonded types: the middle ones of a proper dihedral, the outer
// ones of a type-2 improper, the others "X") or "ai aj ak al func params", as grompp's
// push_dihedraltype. Every line is kept twice, forward and reversed, in grompp's order: the
// lookup's order is grompp's.
void ForceFieldParameters::dihedraltype(const Fields& f) {
  const auto is_function = [&](std::size_t k) {
    return f.size() > k && f[k].size() == 1 && std::isdigit(static_cast<unsigned char>(f[k][0]));
  };
  std::array<std::string, 4> atoms;
  std::size_t first;
  if (is_function(2)) {
    atoms = f[2] == "2" ? std::array{f[0], std::string("X"), std::string("X"), f[1]}
                        : std::array{std::string("X"), f[0], f[1], std::string("X")};
    first = 3;
  } else if (is_function(4)) {
    atoms = {f[0], f[1], f[2], f[3]};
    first = 5;
  } else {
    f.error("[ dihedraltypes ] line needs 2 or 4 bonded type names followed by a function type (one digit)");
  }
  const long func = f.integer(first - 1, "func");
  if (dihedral_function_unsupported(func)) return;  // refused where a dihedral uses it
  const auto function = dihedral_function(func);
  if (!function) f.error("dihedral function type " + f[first - 1] + " does not exist (1, 2, 3, 4, 5, 8, 9, 10, 11)");
  for (const std::string& name : atoms)
    if (name != "X" && !bonded_names_.count(name))
      f.error("unknown bonded type '" + name + "' in [ dihedraltypes ] (no [ atomtypes ] entry has it)");
  DihedralType type{atoms, {}, false, f.where()};
  std::tie(type.params, type.perturbed) = dihedral_parameters(f, first, *function);
  if (type.params.empty())
    f.error("[ dihedraltypes ] line without parameters (" + std::string(function->layout) + ")");
  add_dihedraltype(dihedraltypes_[function->table], std::move(type), func == 9, f);
}

std::vector<double> ForceFieldParameters::bond_parameters(const Fields& f, const std::string& a,
                                                          const std::string& b) const {
  const auto key = ordered(a, b);
  const auto it = bondtypes_.find(key);
  if (it == bondtypes_.end())
    f.error("no parameters for this bond: no [ bondtypes ] entry " + key.first + " " + key.second + " 1");
  return {it->second.first.first, it->second.first.second};
}

std::vector<double> ForceFieldParameters::angle_parameters(const Fields& f, const std::string& a,
                                                           const std::string& b, const std::string& c) const {
  const auto it = angletypes_.find(a <= c ? std::array{a, b, c} : std::array{c, b, a});
  if (it == angletypes_.end())
    f.error("no parameters for this angle: no [ angletypes ] entry " + a + " " + b + " " + c + " 1");
  return {it->second.first.first, it->second.first.second};
}

std::vector<double> ForceFieldParameters::constraint_parameters(const Fields& f, long func, const std::string& a,
                                                                const std::string& b) const {
  const auto key = std::pair{static_cast<int>(func), ordered(a, b)};
  const auto it = constrainttypes_.find(key);
  if (it == constrainttypes_.end())
    f.error("no parameters for this constraint: no [ constrainttypes ] entry " + key.second.first + " " +
            key.second.second + " " + f[2]);
  return {it->second.first};
}

std::pair<double, double> ForceFieldParameters::pair14_lennard_jones(const Fields& f, const AtomType& a,
                                                                     const AtomType& b) const {
  if (const auto it = pairtypes_.find(ordered(a.name, b.name)); it != pairtypes_.end())
    return lj_coefficients(it->second.first.first, it->second.first.second);
  if (!gen_pairs_)
    f.error("no parameters for this 1-4 pair: no [ pairtypes ] entry " + a.name + " " + b.name +
            " 1, and [ defaults ] (at " + defaults_where_.str() + ") has gen-pairs no");
  const auto [c6, c12] = lennard_jones(a, b);
  return {fudge_lj_ * c6, fudge_lj_ * c12};
}

// grompp's defaultInteractionsOfType: of the types matching the bonded type names (a name, or
// X for any), the first with the most non-X matches; and, after it, each next line (two entries
// on: they are kept forward and reversed) with the same atoms, for blocks of type-9 lines.
// Fourier types (table 5) match exactly, X matching nothing, as in grompp.
std::vector<const DihedralType*> ForceFieldParameters::find_dihedraltypes(
    int table, const std::array<std::string, 4>& names) const {
  const auto it = dihedraltypes_.find(table);
  if (it == dihedraltypes_.end()) return {};
  const std::vector<DihedralType>& types = it->second;
  const auto exact_matches = [&](const DihedralType& t) {
    int exact = 0;
    for (int x = 0; x < 4; ++x) {
      if (t.atoms[x] == names[x] && t.atoms[x] != "X") ++exact;
      else if (t.atoms[x] != "X" || table == 5) return -1;
    }
    return exact;
  };
  int best = -1, most = -1;
  for (std::size_t k = 0; k < types.size() && most < 4; ++k) {
    const int exact = exact_matches(types[k]);
    if (exact > most) most = exact, best = static_cast<int>(k);
  }
  if (best < 0) return {};
  std::vector<const DihedralType*> found{&types[best]};
  for (std::size_t k = best + 2; k < types.size() && types[k].atoms == types[best].atoms; k += 2)
    found.push_back(&types[k]);
  return found;
}

// grompp's set_ljparams: with rules 2, 3 a negative sigma means c6 = 0.
std::pair<double, double> ForceFieldParameters::lj_coefficients(double v, double w) const {
  if (*comb_rule_ == 1) return {v, w};
  const double sigma6 = std::pow(std::abs(v), 6);
  return {v < 0 ? 0.0 : 4 * w * sigma6, 4 * w * sigma6 * sigma6};
}

std::pair<double, double> ForceFieldParameters::lennard_jones(const AtomType& a, const AtomType& b) const {
  double v, w;
  if (const auto it = nonbond_params_.find(ordered(a.name, b.name)); it != nonbond_params_.end()) {
    std::tie(v, w) = it->second.first;
  } else if (*comb_rule_ == 1) {
    v = std::sqrt(a.v * b.v);
    w = std::sqrt(a.w * b.w);
  } else {
    // A negative sigma means c6 = 0 (GROMACS convention), carried through the combination.
    v = *comb_rule_ == 2 ? 0.5 * (std::abs(a.v) + std::abs(b.v)) : std::sqrt(std::abs(a.v * b.v));
    if (a.v < 0 || b.v < 0) v = -v;
    w = std::sqrt(a.w * b.w);
  }
  return lj_coefficients(v, w);
}

}  // namespace vimd::top
