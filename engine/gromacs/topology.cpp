#include "engine/gromacs/topology.hpp"

#include <algorithm>
#include <array>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <map>
#include <memory>
#include <numbers>
#include <optional>
#include <set>
#include <string>
#include <string_view>
#include <tuple>
#include <unordered_map>

#include "engine/errors.hpp"
#include "engine/gromacs/top_preprocessor.hpp"

namespace vimd {
namespace fs = std::filesystem;

namespace {

using top::fail;
using top::LogicalLine;
using top::Preprocessor;
using top::split_words;
using top::trim;
using top::Where;

std::string format_number(double value) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", value);
  return buf;
}

std::string lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

// ---------------------------------------------------------------------------------------------
// Topology model.

struct AtomType {
  std::string name, bonded_name;
  double mass, charge;
  char ptype;
  double v, w;  // c6, c12 (comb-rule 1) or sigma, epsilon (comb-rules 2, 3)
  Where where;
};

struct MoleculeAtom {
  int type;
  int residue_number;
  std::string residue_name, name;
  double charge, mass;
  char ptype;
  Where where;
};

// A [ virtual_sites2 ] or [ virtual_sites3 ] line.
struct SiteLine {
  VirtualSite site;
  Where where;
  std::string section;
};

struct Unsupported {
  Where where;
  std::string what;
};

struct MoleculeType {
  std::string name;
  int nrexcl = 0;
  Where where;
  std::vector<MoleculeAtom> atoms;
  std::vector<Bond> bonds;
  std::vector<Angle> angles;
  std::vector<PeriodicDihedral> proper_dihedrals, periodic_impropers;
  std::vector<RyckaertBellemansDihedral> rb_dihedrals;
  std::vector<HarmonicImproper> harmonic_impropers;
  std::vector<Pair14> pairs14;
  std::vector<Constraint> constraints;
  int bonds_constrained = 0;  // of the constraints: bonds made rigid by the constraints option
  std::vector<Where> constraint_lines;  // per constraint: the [ constraints ] or [ settles ] line
  std::vector<std::pair<int, int>> chemical_bonds;  // the graph nrexcl counts along
  std::vector<std::pair<int, int>> explicit_exclusions;
  std::vector<SiteLine> sites;  // in file order
  std::optional<Unsupported> unsupported;  // the first entry vimd cannot compute

  void mark_unsupported(const Where& where, const std::string& what) {
    if (!unsupported) unsupported = Unsupported{where, what};
  }
};

// A [ dihedraltypes ] line as grompp keeps it: bonded type names ("X": any), and the A-state
// parameters; `perturbed` when a B state differs (free-energy perturbation, refused where used).
struct DihedralType {
  std::array<std::string, 4> atoms;
  std::vector<double> params;
  bool perturbed = false;
  Where where;
};

// GROMACS's dihedral function types: the parameter table a type's [ dihedraltypes ] go to (9
// shares type 1's), and the number of A- and B-state parameters.
struct DihedralFunction {
  int table;
  std::size_t n_a, n_b;
  const char* layout;
};

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

// Dihedral function types GROMACS has but vimd does not compute: tabulated, restricted, CBT.
bool dihedral_function_unsupported(long func) { return func == 8 || func == 10 || func == 11; }

struct MoleculeCount {
  int type;
  int count;
};

// Redefinitions with identical values are harmless; different values are an error (grompp
// treats them as a warning, which is fatal without -maxwarn).
template <class Key, class Params>
void define_parameters(std::map<Key, std::pair<Params, Where>>& table, const Key& key, const Params& params,
                       const Where& where, const std::string& what) {
  const auto [it, inserted] = table.try_emplace(key, params, where);
  if (!inserted && it->second.first != params)
    fail(where, what + " redefined with different parameters (first defined at " + it->second.second.str() + ")");
}

enum class Section {
  Defaults,
  AtomTypes,
  NonbondParams,
  BondTypes,
  ConstraintTypes,
  AngleTypes,
  PairTypes,
  DihedralTypes,
  IgnoredTypes,
  MoleculeType,
  Atoms,
  Bonds,
  Angles,
  Dihedrals,
  Pairs,
  Constraints,
  Settles,
  Exclusions,
  VirtualSites2,
  VirtualSites3,
  UnsupportedInteraction,
  System,
  Molecules,
};

struct SectionInfo {
  Section section;
  const char* unsupported_what = "";
};

const std::map<std::string, SectionInfo>& section_table() {
  static const std::map<std::string, SectionInfo> table = {
      {"defaults", {Section::Defaults}},
      {"atomtypes", {Section::AtomTypes}},
      {"nonbond_params", {Section::NonbondParams}},
      {"bondtypes", {Section::BondTypes}},
      {"constrainttypes", {Section::ConstraintTypes}},
      {"angletypes", {Section::AngleTypes}},
      {"pairtypes", {Section::PairTypes}},
      {"dihedraltypes", {Section::DihedralTypes}},
      // Parameter tables only matter through interactions that use them, which are refused.
      {"cmaptypes", {Section::IgnoredTypes}},
      {"implicit_genborn_params", {Section::IgnoredTypes}},
      {"implicit_surface_params", {Section::IgnoredTypes}},
      {"moleculetype", {Section::MoleculeType}},
      {"atoms", {Section::Atoms}},
      {"bonds", {Section::Bonds}},
      {"angles", {Section::Angles}},
      {"constraints", {Section::Constraints}},
      {"settles", {Section::Settles}},
      {"exclusions", {Section::Exclusions}},
      {"pairs", {Section::Pairs}},
      {"pairs_nb", {Section::UnsupportedInteraction, "nonbonded pair interactions ([ pairs_nb ])"}},
      {"dihedrals", {Section::Dihedrals}},
      {"cmap", {Section::UnsupportedInteraction, "CMAP corrections ([ cmap ])"}},
      {"position_restraints", {Section::UnsupportedInteraction, "position restraints ([ position_restraints ])"}},
      {"distance_restraints", {Section::UnsupportedInteraction, "distance restraints ([ distance_restraints ])"}},
      {"dihedral_restraints", {Section::UnsupportedInteraction, "dihedral restraints ([ dihedral_restraints ])"}},
      {"orientation_restraints",
       {Section::UnsupportedInteraction, "orientation restraints ([ orientation_restraints ])"}},
      {"angle_restraints", {Section::UnsupportedInteraction, "angle restraints ([ angle_restraints ])"}},
      {"angle_restraints_z", {Section::UnsupportedInteraction, "angle restraints ([ angle_restraints_z ])"}},
      {"polarization", {Section::UnsupportedInteraction, "polarization ([ polarization ])"}},
      {"water_polarization", {Section::UnsupportedInteraction, "water polarization ([ water_polarization ])"}},
      {"thole_polarization", {Section::UnsupportedInteraction, "Thole polarization ([ thole_polarization ])"}},
      {"virtual_sites1", {Section::UnsupportedInteraction, "virtual sites ([ virtual_sites1 ])"}},
      {"virtual_sites2", {Section::VirtualSites2}},
      {"virtual_sites3", {Section::VirtualSites3}},
      {"virtual_sites4", {Section::UnsupportedInteraction, "virtual sites ([ virtual_sites4 ])"}},
      {"virtual_sitesn", {Section::UnsupportedInteraction, "virtual sites ([ virtual_sitesn ])"}},
      {"dummies2", {Section::VirtualSites2}},  // the old names, still read by grompp
      {"dummies3", {Section::VirtualSites3}},
      {"dummies4", {Section::UnsupportedInteraction, "virtual sites ([ dummies4 ])"}},
      {"dummiesn", {Section::UnsupportedInteraction, "virtual sites ([ dummiesn ])"}},
      {"system", {Section::System}},
      {"molecules", {Section::Molecules}},
  };
  return table;
}

// One data line split into fields, with typed accessors whose errors name the column.
class Fields {
 public:
  Fields(const LogicalLine& line, const char* section) : words_(split_words(line.text)), where_(line.where),
                                                         section_(section) {}
  std::size_t size() const { return words_.size(); }
  const std::string& operator[](std::size_t k) const { return words_[k]; }
  const Where& where() const { return where_; }

  void require(std::size_t n, const char* layout) const {
    if (words_.size() < n)
      fail(where_, "[ " + section_ + " ] line has " + std::to_string(words_.size()) + " fields, expected at least " +
                       std::to_string(n) + ": " + layout);
  }
  double number(std::size_t k, const char* what) const {
    double value = 0;
    const std::string& s = words_.at(k);
    const char* begin = s.data() + (s.size() > 1 && s[0] == '+');  // from_chars rejects a leading '+'
    const auto [end, ec] = std::from_chars(begin, s.data() + s.size(), value);
    if (ec != std::errc() || end != s.data() + s.size() || !std::isfinite(value))
      fail(where_, "[ " + section_ + " ] field " + std::to_string(k + 1) + " (" + what + ") is not a number: '" + s +
                       "'");
    return value;
  }
  long integer(std::size_t k, const char* what) const {
    long value = 0;
    const std::string& s = words_.at(k);
    const char* begin = s.data() + (s.size() > 1 && s[0] == '+');
    const auto [end, ec] = std::from_chars(begin, s.data() + s.size(), value);
    if (ec != std::errc() || end != s.data() + s.size())
      fail(where_, "[ " + section_ + " ] field " + std::to_string(k + 1) + " (" + what + ") is not an integer: '" + s +
                       "'");
    return value;
  }
  // A 1-based atom number inside the current molecule, returned 0-based.
  int atom(std::size_t k, const MoleculeType& molecule) const {
    const long index = integer(k, "atom number");
    if (index < 1 || index > static_cast<long>(molecule.atoms.size()))
      fail(where_, "atom number " + std::to_string(index) + " is out of range: molecule type '" + molecule.name +
                       "' has " + std::to_string(molecule.atoms.size()) + " atoms (defined so far)");
    return static_cast<int>(index - 1);
  }
  // Numbers after the first `first` fields.
  std::vector<double> numbers_from(std::size_t first, const char* what) const {
    std::vector<double> values;
    for (std::size_t k = first; k < words_.size(); ++k) values.push_back(number(k, what));
    return values;
  }
  [[noreturn]] void error(const std::string& problem) const { fail(where_, problem); }

 private:
  std::vector<std::string> words_;
  Where where_;
  std::string section_;
};

class TopologyParser {
 public:
  TopologyParser(const fs::path& top, BondConstraints bond_constraints)
      : top_(top), pre_(top, gromacs_library_dirs()), bond_constraints_(bond_constraints) {}

  System parse() {
    LogicalLine line;
    while (pre_.next(line)) {
      if (line.text.front() == '[') {
        header(line);
        continue;
      }
      // GROMACS ignores text before the first section (AMBER and CHARMM force fields open with a
      // banner of asterisks).
      if (section_) data(line);
    }
    if (molecule_counts_.empty()) throw InputError(top_.string(), 0, "no molecules: the topology has no [ molecules ] entries");
    return build();
  }

 private:
  void header(const LogicalLine& line) {
    const auto close = line.text.find(']');
    if (close == std::string::npos || !trim(std::string_view(line.text).substr(close + 1)).empty())
      fail(line.where, "malformed section header '" + line.text + "', expected e.g. [ atoms ]");
    section_name_ = lower(std::string(trim(std::string_view(line.text).substr(1, close - 1))));
    if (section_name_ == "intermolecular_interactions")
      fail(line.where, "[ intermolecular_interactions ] are not supported by vimd");
    const auto it = section_table().find(section_name_);
    if (it == section_table().end()) fail(line.where, "unknown section [ " + section_name_ + " ]");
    section_ = it->second;
    if (section_->section != Section::Defaults && !comb_rule_)
      fail(line.where, "[ " + section_name_ + " ] before [ defaults ]: the force field's [ defaults ] must come first");
    const bool molecule_level = section_->section >= Section::Atoms && section_->section <= Section::UnsupportedInteraction;
    if (molecule_level && molecules_.empty())
      fail(line.where, "[ " + section_name_ + " ] outside a [ moleculetype ]");
  }

  void data(const LogicalLine& line) {
    const Fields f(line, section_name_.c_str());
    switch (section_->section) {
      case Section::Defaults: defaults(f); break;
      case Section::AtomTypes: atomtype(f); break;
      case Section::NonbondParams: nonbond_params(f); break;
      case Section::BondTypes: bondtype(f); break;
      case Section::ConstraintTypes: constrainttype(f); break;
      case Section::AngleTypes: angletype(f); break;
      case Section::PairTypes: pairtype(f); break;
      case Section::DihedralTypes: dihedraltype(f); break;
      case Section::IgnoredTypes: break;
      case Section::MoleculeType: moleculetype(f); break;
      case Section::Atoms: atom(f); break;
      case Section::Bonds: bond(f); break;
      case Section::Angles: angle(f); break;
      case Section::Dihedrals: dihedral(f); break;
      case Section::Pairs: pair(f); break;
      case Section::Constraints: constraint(f); break;
      case Section::Settles: settle(f); break;
      case Section::Exclusions: exclusion(f); break;
      case Section::VirtualSites2: virtual_site(f, 2); break;
      case Section::VirtualSites3: virtual_site(f, 3); break;
      case Section::UnsupportedInteraction:
        molecules_.back().mark_unsupported(f.where(), std::string(section_->unsupported_what) + " are not supported");
        break;
      case Section::System: title_ += (title_.empty() ? "" : " ") + line.text; break;
      case Section::Molecules: molecule_count(f); break;
    }
  }

  void defaults(const Fields& f) {
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
  void atomtype(const Fields& f) {
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

  const AtomType& atomtype_named(const Fields& f, std::size_t k) const {
    const auto it = atomtype_index_.find(f[k]);
    if (it == atomtype_index_.end()) f.error("unknown atom type '" + f[k] + "' (not defined in [ atomtypes ])");
    return atomtypes_[it->second];
  }

  static std::pair<std::string, std::string> ordered(std::string a, std::string b) {
    if (b < a) std::swap(a, b);
    return {std::move(a), std::move(b)};
  }

  void nonbond_params(const Fields& f) {
    f.require(5, "type_i type_j func V W");
    if (f.integer(2, "func") != 1) f.error("[ nonbond_params ] function type " + f[2] + " is not supported (only 1, LJ)");
    const auto& a = atomtype_named(f, 0);
    const auto& b = atomtype_named(f, 1);
    define_parameters(nonbond_params_, ordered(a.name, b.name), std::pair{f.number(3, "V"), f.number(4, "W")},
                      f.where(), "[ nonbond_params ] " + a.name + " " + b.name);
  }

  void bondtype(const Fields& f) {
    f.require(3, "type_i type_j func parameters");
    // Other bond functions cannot be computed; bonds that use them are refused where they occur.
    if (f.integer(2, "func") != 1) return;
    f.require(5, "type_i type_j 1 b0 kb");
    define_parameters(bondtypes_, ordered(f[0], f[1]), std::pair{f.number(3, "b0"), f.number(4, "kb")}, f.where(),
                      "[ bondtypes ] " + f[0] + " " + f[1]);
  }

  void constrainttype(const Fields& f) {
    f.require(4, "type_i type_j func b0");
    const long func = f.integer(2, "func");
    if (func != 1 && func != 2) f.error("constraint function type " + f[2] + " does not exist (1 or 2)");
    define_parameters(constrainttypes_, std::pair{static_cast<int>(func), ordered(f[0], f[1])}, f.number(3, "b0"),
                      f.where(), "[ constrainttypes ] " + f[0] + " " + f[1]);
  }

  void angletype(const Fields& f) {
    f.require(4, "type_i type_j type_k func parameters");
    if (f.integer(3, "func") != 1) return;  // as for bondtypes
    f.require(6, "type_i type_j type_k 1 theta0 k");
    // i-j-k and k-j-i are the same angle.
    auto key = f[0] <= f[2] ? std::array{f[0], f[1], f[2]} : std::array{f[2], f[1], f[0]};
    define_parameters(angletypes_, key, std::pair{f.number(4, "theta0"), f.number(5, "k")}, f.where(),
                      "[ angletypes ] " + f[0] + " " + f[1] + " " + f[2]);
  }

  // Keyed by (nonbonded) atom type names, as grompp's pair parameters.
  void pairtype(const Fields& f) {
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
  void dihedraltype(const Fields& f) {
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

  // grompp's push_bondtype for dihedrals: a line with the atoms of an earlier one (either
  // direction) and the same parameters is dropped; with other parameters it is an error (grompp's
  // warning, fatal without -maxwarn), except for type 9, where lines for the same atoms next to
  // each other add terms.
  static void add_dihedraltype(std::vector<DihedralType>& table, DihedralType type, bool allow_repeat, const Fields& f) {
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

  // Parameters from field `first` on: n_a A-state values, optionally followed by n_b B-state ones
  // (which, differing from the A state's first n_b, mark free-energy perturbation). Empty if none.
  static std::pair<std::vector<double>, bool> dihedral_parameters(const Fields& f, std::size_t first,
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

  void moleculetype(const Fields& f) {
    f.require(2, "name nrexcl");
    const long nrexcl = f.integer(1, "nrexcl");
    if (nrexcl < 0) f.error("nrexcl must not be negative");
    for (const auto& m : molecules_)
      if (m.name == f[0]) f.error("molecule type '" + f[0] + "' already defined at " + m.where.str());
    MoleculeType& molecule = molecules_.emplace_back();
    molecule.name = f[0];
    molecule.nrexcl = static_cast<int>(nrexcl);
    molecule.where = f.where();
  }

  // Residue numbers may carry an insertion code, e.g. 12A.
  static int residue_number(const Fields& f, std::size_t k) {
    const std::string& s = f[k];
    int value = 0;
    const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), value);
    const std::size_t rest = s.data() + s.size() - end;
    if (ec != std::errc() || rest > 1 || (rest == 1 && !std::isalpha(static_cast<unsigned char>(*end))))
      f.error("[ atoms ] field " + std::to_string(k + 1) + " (residue number) is not an integer: '" + s + "'");
    return value;
  }

  void atom(const Fields& f) {
    f.require(5, "nr type resnr residue atom [cgnr charge mass]");
    MoleculeType& molecule = molecules_.back();
    const long nr = f.integer(0, "atom number");
    if (nr != static_cast<long>(molecule.atoms.size()) + 1)
      f.error("atoms must be numbered consecutively: expected " + std::to_string(molecule.atoms.size() + 1) +
              ", found " + f[0]);
    const AtomType& type = atomtype_named(f, 1);
    MoleculeAtom a{atomtype_index_.at(type.name), residue_number(f, 2), f[3], f[4],
                   f.size() > 6 ? f.number(6, "charge") : type.charge, f.size() > 7 ? f.number(7, "mass") : type.mass,
                   type.ptype, f.where()};
    if (f.size() > 8) {
      const AtomType& type_b = atomtype_named(f, 8);
      const double charge_b = f.size() > 9 ? f.number(9, "chargeB") : type_b.charge;
      const double mass_b = f.size() > 10 ? f.number(10, "massB") : type_b.mass;
      if (type_b.name != type.name || charge_b != a.charge || mass_b != a.mass)
        molecule.mark_unsupported(f.where(), "free-energy perturbation (B-state type, charge or mass) is not supported");
    }
    if (type.ptype == 'S' || type.ptype == 'B')
      molecule.mark_unsupported(f.where(), "atom '" + a.name + "' has particle type " + std::string(1, type.ptype) +
                                               " (a shell), which is not supported");
    // Masses are checked with the molecule's virtual sites (check_sites): a site has none.
    molecule.atoms.push_back(std::move(a));
  }

  const std::string& bonded_name(const MoleculeType& molecule, int atom) const {
    return atomtypes_[molecule.atoms[atom].type].bonded_name;
  }

  // Inline parameters: `n` A-state values, optionally followed by an identical B state.
  static std::optional<std::vector<double>> inline_parameters(const Fields& f, std::size_t first, std::size_t n,
                                                              const char* layout, MoleculeType& molecule) {
    auto values = f.numbers_from(first, "parameter");
    if (values.empty()) return std::nullopt;
    if (values.size() != n && values.size() != 2 * n)
      f.error("expected " + std::to_string(n) + " parameters (" + layout + ") or none to use the force field's, found " +
              std::to_string(values.size()));
    if (values.size() == 2 * n && !std::equal(values.begin(), values.begin() + n, values.begin() + n))
      molecule.mark_unsupported(f.where(), "free-energy perturbation (B-state parameters) is not supported");
    values.resize(n);
    return values;
  }

  void bond(const Fields& f) {
    f.require(3, "ai aj func [parameters]");
    MoleculeType& molecule = molecules_.back();
    const int i = f.atom(0, molecule), j = f.atom(1, molecule);
    if (i == j) f.error("bond between an atom and itself");
    const long func = f.integer(2, "func");
    if (func == 5) {  // a connection: only for exclusions
      molecule.chemical_bonds.emplace_back(i, j);
      return;
    }
    if (func != 1) {
      molecule.mark_unsupported(f.where(), "bond function type " + f[2] + " is not supported (only 1, harmonic, and 5, connection)");
      return;
    }
    auto params = inline_parameters(f, 3, 2, "b0 kb", molecule);
    if (!params) {
      const auto key = ordered(bonded_name(molecule, i), bonded_name(molecule, j));
      const auto it = bondtypes_.find(key);
      if (it == bondtypes_.end())
        f.error("no parameters for this bond: no [ bondtypes ] entry " + key.first + " " + key.second + " 1");
      params = std::vector{it->second.first.first, it->second.first.second};
    }
    if ((*params)[0] < 0 || (*params)[1] < 0)
      f.error("bond length b0 and force constant kb must not be negative (b0 " + format_number((*params)[0]) + " nm, kb " +
              format_number((*params)[1]) + " kJ/mol/nm^2)");
    molecule.chemical_bonds.emplace_back(i, j);
    const bool rigid = bond_constraints_ == BondConstraints::all_bonds ||
                       (bond_constraints_ == BondConstraints::h_bonds &&
                        (hydrogen_like(molecule.atoms[i].name) || hydrogen_like(molecule.atoms[j].name)));
    if (!rigid) {
      molecule.bonds.push_back({i, j, (*params)[0], (*params)[1]});
      return;
    }
    if ((*params)[0] <= 0) f.error("a bond to be made a constraint (option constraints) needs a positive length b0");
    molecule.constraints.push_back({i, j, (*params)[0]});
    molecule.constraint_lines.push_back(f.where());
    ++molecule.bonds_constrained;
  }

  void angle(const Fields& f) {
    f.require(4, "ai aj ak func [parameters]");
    MoleculeType& molecule = molecules_.back();
    const int i = f.atom(0, molecule), j = f.atom(1, molecule), k = f.atom(2, molecule);
    if (i == j || j == k || i == k) f.error("angle with a repeated atom");
    if (f.integer(3, "func") != 1) {
      molecule.mark_unsupported(f.where(), "angle function type " + f[3] + " is not supported (only 1, harmonic)");
      return;
    }
    auto params = inline_parameters(f, 4, 2, "theta0 k", molecule);
    if (!params) {
      const std::string &a = bonded_name(molecule, i), &b = bonded_name(molecule, j), &c = bonded_name(molecule, k);
      const auto it = angletypes_.find(a <= c ? std::array{a, b, c} : std::array{c, b, a});
      if (it == angletypes_.end())
        f.error("no parameters for this angle: no [ angletypes ] entry " + a + " " + b + " " + c + " 1");
      params = std::vector{it->second.first.first, it->second.first.second};
    }
    molecule.angles.push_back({i, j, k, (*params)[0] * std::numbers::pi / 180.0, (*params)[1]});
  }

  void dihedral(const Fields& f) {
    f.require(5, "ai aj ak al func [parameters]");
    MoleculeType& molecule = molecules_.back();
    const std::array<int, 4> a{f.atom(0, molecule), f.atom(1, molecule), f.atom(2, molecule), f.atom(3, molecule)};
    for (int x = 0; x < 4; ++x)
      for (int y = x + 1; y < 4; ++y)
        if (a[x] == a[y]) f.error("dihedral with a repeated atom (" + std::to_string(a[x] + 1) + ")");
    const long func = f.integer(4, "func");
    if (dihedral_function_unsupported(func)) {
      molecule.mark_unsupported(f.where(), "dihedral function type " + f[4] +
                                               " is not supported (only 1, 9 proper, 2 harmonic improper, 3 "
                                               "Ryckaert-Bellemans, 4 periodic improper, 5 Fourier)");
      return;
    }
    const auto function = dihedral_function(func);
    if (!function) f.error("dihedral function type " + f[4] + " does not exist (1, 2, 3, 4, 5, 8, 9, 10, 11)");
    auto [params, perturbed] = dihedral_parameters(f, 5, *function);
    std::vector<std::vector<double>> terms;
    if (!params.empty()) {
      terms.push_back(std::move(params));
    } else {
      const std::array<std::string, 4> names{bonded_name(molecule, a[0]), bonded_name(molecule, a[1]),
                                             bonded_name(molecule, a[2]), bonded_name(molecule, a[3])};
      for (const DihedralType* type : find_dihedraltypes(function->table, names)) {
        terms.push_back(type->params);
        perturbed = perturbed || type->perturbed;
      }
      if (terms.empty())
        f.error("no parameters for this dihedral: no [ dihedraltypes ] entry of function " + f[4] +
                " matches the bonded types " + names[0] + " " + names[1] + " " + names[2] + " " + names[3] +
                " of atoms " + describe(molecule, a[0]) + ", " + describe(molecule, a[1]) + ", " +
                describe(molecule, a[2]) + ", " + describe(molecule, a[3]) + " (X matches any type)");
      // Several terms only from a block of function-9 types, and only for a proper dihedral.
      if (function->table != 1) terms.resize(1);
    }
    if (perturbed)
      molecule.mark_unsupported(f.where(), "free-energy perturbation (B-state parameters) is not supported");
    constexpr double deg = std::numbers::pi / 180.0;
    for (const auto& p : terms) {
      switch (function->table) {
        case 1:
        case 4: {
          const PeriodicDihedral d{a[0], a[1], a[2], a[3], p[0] * deg, p[1], static_cast<int>(p[2])};
          (function->table == 1 ? molecule.proper_dihedrals : molecule.periodic_impropers).push_back(d);
          break;
        }
        case 2: molecule.harmonic_impropers.push_back({a[0], a[1], a[2], a[3], p[0] * deg, p[1]}); break;
        case 3: molecule.rb_dihedrals.push_back({a[0], a[1], a[2], a[3], {p[0], p[1], p[2], p[3], p[4], p[5]}}); break;
        case 5: {
          // grompp converts the Fourier coefficients to Ryckaert–Bellemans ones (convparm.cpp); the
          // identity: ½ [F1 (1 + cos φ) + F2 (1 − cos 2φ) + F3 (1 + cos 3φ) + F4 (1 − cos 4φ)] in
          // powers of cos ψ = −cos φ.
          const double f1 = p[0], f2 = p[1], f3 = p[2], f4 = p[3];
          molecule.rb_dihedrals.push_back({a[0], a[1], a[2], a[3],
                                           {f2 + 0.5 * (f1 + f3), 0.5 * (3.0 * f3 - f1), 4.0 * f4 - f2, -2.0 * f3,
                                            -4.0 * f4, 0.0}});
          break;
        }
      }
    }
  }

  // grompp's defaultInteractionsOfType: of the types matching the bonded type names (a name, or
  // X for any), the first with the most non-X matches; and, after it, each next line (two entries
  // on: they are kept forward and reversed) with the same atoms, for blocks of type-9 lines.
  // Fourier types (table 5) match exactly, X matching nothing, as in grompp.
  std::vector<const DihedralType*> find_dihedraltypes(int table, const std::array<std::string, 4>& names) const {
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

  static std::string describe(const MoleculeType& molecule, int atom) {
    return std::to_string(atom + 1) + " (" + molecule.atoms[atom].name + ")";
  }

  // c6, c12 from V, W as the combination rule reads them (grompp's set_ljparams: with rules 2, 3
  // a negative sigma means c6 = 0).
  std::pair<double, double> lj_coefficients(double v, double w) const {
    if (*comb_rule_ == 1) return {v, w};
    const double sigma6 = std::pow(std::abs(v), 6);
    return {v < 0 ? 0.0 : 4 * w * sigma6, 4 * w * sigma6 * sigma6};
  }

  // A 1–4 pair's LJ: its own parameters, else the [ pairtypes ] of its atom types, else (with
  // gen-pairs) fudgeLJ times the pair's normal LJ, as grompp.
  void pair(const Fields& f) {
    f.require(3, "ai aj func [parameters]");
    MoleculeType& molecule = molecules_.back();
    const int i = f.atom(0, molecule), j = f.atom(1, molecule);
    if (i == j) f.error("1-4 pair of an atom with itself");
    const long func = f.integer(2, "func");
    if (func == 2) {
      molecule.mark_unsupported(f.where(), "1-4 pair function type 2 (pairs with their own charges) is not supported");
      return;
    }
    if (func != 1) f.error("pair function type " + f[2] + " does not exist (1 or 2)");
    auto params = inline_parameters(f, 3, 2, "V W", molecule);
    std::pair<double, double> c6_c12;
    if (params) {
      c6_c12 = lj_coefficients((*params)[0], (*params)[1]);
    } else {
      const AtomType &ta = atomtypes_[molecule.atoms[i].type], &tb = atomtypes_[molecule.atoms[j].type];
      if (const auto it = pairtypes_.find(ordered(ta.name, tb.name)); it != pairtypes_.end()) {
        c6_c12 = lj_coefficients(it->second.first.first, it->second.first.second);
      } else if (gen_pairs_) {
        const auto [c6, c12] = lennard_jones(ta, tb);
        c6_c12 = {fudge_lj_ * c6, fudge_lj_ * c12};
      } else {
        f.error("no parameters for this 1-4 pair: no [ pairtypes ] entry " + ta.name + " " + tb.name +
                " 1, and [ defaults ] (at " + defaults_where_.str() + ") has gen-pairs no");
      }
    }
    molecule.pairs14.push_back(
        {i, j, c6_c12.first, c6_c12.second, fudge_qq_ * molecule.atoms[i].charge * molecule.atoms[j].charge});
  }

  void constraint(const Fields& f) {
    f.require(3, "ai aj func [b0]");
    MoleculeType& molecule = molecules_.back();
    const int i = f.atom(0, molecule), j = f.atom(1, molecule);
    if (i == j) f.error("constraint between an atom and itself");
    const long func = f.integer(2, "func");
    if (func != 1 && func != 2) f.error("constraint function type " + f[2] + " does not exist (1 or 2)");
    auto params = inline_parameters(f, 3, 1, "b0", molecule);
    if (!params) {
      const auto key = std::pair{static_cast<int>(func), ordered(bonded_name(molecule, i), bonded_name(molecule, j))};
      const auto it = constrainttypes_.find(key);
      if (it == constrainttypes_.end())
        f.error("no parameters for this constraint: no [ constrainttypes ] entry " + key.second.first + " " +
                key.second.second + " " + f[2]);
      params = std::vector{it->second.first};
    }
    if ((*params)[0] <= 0) f.error("constraint length must be positive");
    molecule.constraints.push_back({i, j, (*params)[0]});
    molecule.constraint_lines.push_back(f.where());
    if (func == 1) molecule.chemical_bonds.emplace_back(i, j);  // type 2 generates no exclusions
  }

  // A settle is rigid water: oxygen `ow`, hydrogens ow+1, ow+2; three distance constraints.
  void settle(const Fields& f) {
    f.require(4, "OW funct doh dhh");
    MoleculeType& molecule = molecules_.back();
    const int o = f.atom(0, molecule);
    if (f.integer(1, "funct") != 1) f.error("settles function type must be 1");
    if (o + 2 >= static_cast<int>(molecule.atoms.size()))
      f.error("settles needs the two hydrogens right after the oxygen (atoms " + std::to_string(o + 2) + ", " +
              std::to_string(o + 3) + ")");
    const double doh = f.number(2, "doh"), dhh = f.number(3, "dhh");
    if (doh <= 0 || dhh <= 0) f.error("settles distances must be positive");
    molecule.constraints.push_back({o, o + 1, doh});
    molecule.constraints.push_back({o, o + 2, doh});
    molecule.constraints.push_back({o + 1, o + 2, dhh});
    molecule.constraint_lines.insert(molecule.constraint_lines.end(), 3, f.where());
    molecule.chemical_bonds.emplace_back(o, o + 1);
    molecule.chemical_bonds.emplace_back(o, o + 2);
  }

  void exclusion(const Fields& f) {
    f.require(2, "ai aj [ak …]");
    MoleculeType& molecule = molecules_.back();
    const int i = f.atom(0, molecule);
    for (std::size_t k = 1; k < f.size(); ++k) molecule.explicit_exclusions.emplace_back(i, f.atom(k, molecule));
  }

  // "site ai aj [ak] func parameters", as grompp reads [ virtual_sites2 ] (functions 1 "2", 2 "2fd")
  // and [ virtual_sites3 ] (1 "3", 2 "3fd", 3 "3fad" with theta in degrees, 4 "3out").
  void virtual_site(const Fields& f, int from) {
    const std::size_t func_field = static_cast<std::size_t>(from) + 1;
    f.require(func_field + 1, from == 2 ? "site ai aj func parameters" : "site ai aj ak func parameters");
    MoleculeType& molecule = molecules_.back();
    VirtualSite v{};
    v.site = f.atom(0, molecule);
    v.i = f.atom(1, molecule);
    v.j = f.atom(2, molecule);
    v.k = from == 3 ? f.atom(3, molecule) : -1;
    if (v.site == v.i || v.site == v.j || v.site == v.k || v.i == v.j || v.i == v.k || (v.k >= 0 && v.j == v.k))
      f.error("a virtual site and the atoms it is built from must all be different atoms");
    struct Function {
      VirtualSite::Kind kind;
      std::size_t n;
      const char* layout;
    };
    using enum VirtualSite::Kind;
    static const std::map<std::pair<int, long>, Function> functions = {
        {{2, 1}, {two, 1, "a"}},         {{2, 2}, {two_fd, 1, "d (nm)"}},
        {{3, 1}, {three, 2, "a b"}},     {{3, 2}, {three_fd, 2, "a d (nm)"}},
        {{3, 3}, {three_fad, 2, "theta (deg) d (nm)"}}, {{3, 4}, {three_out, 3, "a b c (1/nm)"}},
    };
    const auto it = functions.find({from, f.integer(func_field, "func")});
    if (it == functions.end())
      f.error("[ " + section_name_ + " ] function type " + f[func_field] + " does not exist (" +
              (from == 2 ? "1: 2, 2: 2fd" : "1: 3, 2: 3fd, 3: 3fad, 4: 3out") + ")");
    const Function& function = it->second;
    const auto params = f.numbers_from(func_field + 1, "parameter");
    if (params.empty())
      f.error("virtual site without parameters: vimd needs them on the line (" + std::string(function.layout) +
              "); grompp's derivation from bond and angle geometry is not supported");
    if (params.size() != function.n)
      f.error("expected " + std::to_string(function.n) + " parameters (" + function.layout + "), found " +
              std::to_string(params.size()));
    v.kind = function.kind;
    if (v.kind == three_fad) {
      const double theta = params[0] * std::numbers::pi / 180;
      v.a = params[1] * std::cos(theta);
      v.b = params[1] * std::sin(theta);
    } else {
      v.a = params[0];
      v.b = params.size() > 1 ? params[1] : 0;
      v.c = params.size() > 2 ? params[2] : 0;
    }
    molecule.sites.push_back({v, f.where(), section_name_});
  }

  // grompp's construction order: by function (2, 2fd, 3, 3fd, 3fad, 3out), each in file order.
  static std::vector<SiteLine> construction_order(const MoleculeType& m) {
    std::vector<SiteLine> order = m.sites;
    std::stable_sort(order.begin(), order.end(),
                     [](const SiteLine& x, const SiteLine& y) { return x.site.kind < y.site.kind; });
    return order;
  }

  // grompp's rules: a site is constructed once, from atoms constructed before it, has mass 0 and
  // no constraint; every other atom is a particle with a positive mass.
  static void check_sites(const MoleculeType& m) {
    const auto name = [&](int a) { return std::to_string(a + 1) + " (" + m.atoms[a].name + ")"; };
    const auto order = construction_order(m);
    std::vector<int> built_at(m.atoms.size(), -1);  // position in `order`
    for (std::size_t s = 0; s < order.size(); ++s) {
      const int site = order[s].site.site;
      if (built_at[site] >= 0)
        fail(order[s].where, "atom " + name(site) + " of molecule type '" + m.name +
                                 "' is constructed twice as a virtual site (also at " +
                                 order[built_at[site]].where.str() + ")");
      built_at[site] = static_cast<int>(s);
    }
    for (std::size_t s = 0; s < order.size(); ++s) {
      const SiteLine& line = order[s];
      const MoleculeAtom& atom = m.atoms[line.site.site];
      if (atom.mass != 0)
        fail(line.where, "virtual site " + name(line.site.site) + " of molecule type '" + m.name + "' has mass " +
                             format_number(atom.mass) + " amu (its [ atoms ] line is " + atom.where.str() +
                             "): a virtual site must have mass 0, its motion follows from the atoms it is built from");
      for (int from : {line.site.i, line.site.j, line.site.k}) {
        if (from < 0) continue;
        if (built_at[from] > static_cast<int>(s))
          fail(line.where, "virtual site " + name(line.site.site) + " is built from atom " + name(from) +
                               ", a virtual site constructed after it (at " + order[built_at[from]].where.str() +
                               "): grompp constructs by function (2, 2fd, 3, 3fd, 3fad, 3out), each in file order");
        if (built_at[from] < 0 && (m.atoms[from].ptype == 'V' || m.atoms[from].ptype == 'D'))
          fail(line.where, "virtual site " + name(line.site.site) + " is built from atom " + name(from) +
                               ", which has particle type " + std::string(1, m.atoms[from].ptype) +
                               " (a virtual site) but is never constructed");
      }
    }
    for (std::size_t c = 0; c < m.constraints.size(); ++c)
      for (int a : {m.constraints[c].i, m.constraints[c].j})
        if (built_at[a] >= 0)
          fail(m.constraint_lines[c], "a constraint between atoms " + name(m.constraints[c].i) + " and " +
                                          name(m.constraints[c].j) + " of molecule type '" + m.name +
                                          "' involves atom " + name(a) + ", a virtual site (constructed at " +
                                          order[built_at[a]].where.str() +
                                          "): a virtual site cannot be constrained; constrain the atoms it is built from");
    for (std::size_t a = 0; a < m.atoms.size(); ++a) {
      const MoleculeAtom& atom = m.atoms[a];
      if (built_at[a] >= 0) continue;
      if (atom.ptype == 'V' || atom.ptype == 'D')
        fail(atom.where, "atom '" + atom.name + "' has particle type " + std::string(1, atom.ptype) +
                             " (a virtual site), but no [ virtual_sites2 ] or [ virtual_sites3 ] line constructs it");
      if (atom.mass <= 0)
        fail(atom.where, "atom '" + atom.name + "' has mass " + format_number(atom.mass) +
                             " amu: every atom needs a positive mass (the equations of motion and the constraint "
                             "solver divide by it); only a virtual site has none");
    }
  }

  void molecule_count(const Fields& f) {
    f.require(2, "name count");
    const auto it = std::find_if(molecules_.begin(), molecules_.end(), [&](const auto& m) { return m.name == f[0]; });
    if (it == molecules_.end()) f.error("no [ moleculetype ] named '" + f[0] + "'");
    const long count = f.integer(1, "count");
    if (count <= 0) f.error("molecule count must be positive, found " + f[1]);
    if (it->unsupported)
      fail(it->unsupported->where, "molecule type '" + it->name + "' (used in [ molecules ] at " + f.where().str() +
                                       "): " + it->unsupported->what);
    if (it->atoms.empty()) f.error("molecule type '" + it->name + "' has no atoms");
    check_sites(*it);
    check_constraint_set(*it);
    // A typo such as an extra digit must not become an attempt to allocate billions of atoms.
    constexpr long kMaxAtoms = 10'000'000;
    const long atoms = static_cast<long>(it->atoms.size());
    if (count > kMaxAtoms / atoms || total_atoms_ + count * atoms > kMaxAtoms)
      f.error("'" + it->name + " " + f[1] + "' makes the system larger than vimd's limit of " +
              std::to_string(kMaxAtoms) + " atoms (a typo in the count?)");
    total_atoms_ += count * atoms;
    molecule_counts_.push_back({static_cast<int>(it - molecules_.begin()), static_cast<int>(count)});
  }

  // The constraints of a molecule must be independent, or the constraint matrix G M⁻¹ Gᵀ is singular
  // and no solver converges: no pair twice, no flat or impossible triangle, and no cluster of N atoms
  // with more than the 3N − 6 distances a rigid body has.
  static void check_constraint_set(const MoleculeType& m) {
    const auto& list = m.constraints;
    const auto& lines = m.constraint_lines;
    std::map<std::pair<int, int>, int> index;  // atom pair (i < j) -> constraint
    for (std::size_t a = 0; a < list.size(); ++a) {
      const auto [it, inserted] = index.try_emplace(std::minmax(list[a].i, list[a].j), static_cast<int>(a));
      if (!inserted)
        fail(lines[a], "atoms " + std::to_string(list[a].i + 1) + " and " + std::to_string(list[a].j + 1) +
                           " of molecule type '" + m.name + "' are constrained twice (first at " +
                           lines[it->second].str() + "): the constraint set is over-determined");
    }
    std::vector<std::vector<int>> partners(m.atoms.size());
    for (const Constraint& c : list) {
      partners[c.i].push_back(c.j);
      partners[c.j].push_back(c.i);
    }
    for (const auto& [pair, ab] : index)
      for (int k : partners[pair.first]) {
        if (k <= pair.second) continue;  // each triangle once, from its two smallest atoms
        const auto jk = index.find(std::minmax(pair.second, k));
        if (jk == index.end()) continue;
        const int ak = index.at(std::minmax(pair.first, k));
        std::array<double, 3> d{list[ab].length, list[ak].length, list[jk->second].length};
        std::sort(d.begin(), d.end());
        if (d[2] < (d[0] + d[1]) * (1 - 1e-6)) continue;
        const int last = std::max({ab, ak, jk->second});
        fail(lines[last], "the constraints between atoms " + std::to_string(pair.first + 1) + ", " +
                              std::to_string(pair.second + 1) + " and " + std::to_string(k + 1) + " of molecule type '" +
                              m.name + "' form " + (d[2] > d[0] + d[1] ? "an impossible" : "a flat") + " triangle (" +
                              format_number(d[0]) + " + " + format_number(d[1]) + " vs " + format_number(d[2]) +
                              " nm): the three constraints are not independent (over-determined)");
      }
    // Clusters of coupled constraints (union-find over atoms).
    std::vector<int> parent(m.atoms.size());
    for (std::size_t k = 0; k < parent.size(); ++k) parent[k] = static_cast<int>(k);
    const auto root = [&](int k) {
      while (parent[k] != k) k = parent[k] = parent[parent[k]];
      return k;
    };
    for (const Constraint& c : list) parent[root(c.i)] = root(c.j);
    std::map<int, std::set<int>> atoms;
    std::map<int, int> count, last;
    for (std::size_t a = 0; a < list.size(); ++a) {
      const int r = root(list[a].i);
      atoms[r].insert(list[a].i);
      atoms[r].insert(list[a].j);
      ++count[r];
      last[r] = static_cast<int>(a);
    }
    for (const auto& [r, members] : atoms) {
      const int n = static_cast<int>(members.size());
      if (n < 3 || count[r] <= 3 * n - 6) continue;
      fail(lines[last[r]], std::to_string(count[r]) + " constraints join " + std::to_string(n) + " atoms (" +
                               std::to_string(*members.begin() + 1) + ".." + std::to_string(*members.rbegin() + 1) +
                               ") of molecule type '" + m.name + "', but a rigid body of " + std::to_string(n) +
                               " atoms has only " + std::to_string(3 * n - 6) +
                               " independent distances: the constraint set is over-determined");
    }
  }

  // Per atom of a molecule type: the atoms within nrexcl chemical bonds plus [ exclusions ].
  static std::vector<std::vector<int>> molecule_exclusions(const MoleculeType& m) {
    const int n = static_cast<int>(m.atoms.size());
    std::vector<std::vector<int>> neighbours(n), excluded(n);
    for (auto [i, j] : m.chemical_bonds) {
      neighbours[i].push_back(j);
      neighbours[j].push_back(i);
    }
    std::vector<int> distance(n, -1);
    for (int start = 0; start < n; ++start) {
      std::vector<int> frontier{start}, reached{start};
      distance[start] = 0;
      for (int depth = 1; depth <= m.nrexcl && !frontier.empty(); ++depth) {
        std::vector<int> next;
        for (int a : frontier)
          for (int b : neighbours[a])
            if (distance[b] < 0) {
              distance[b] = depth;
              next.push_back(b);
              reached.push_back(b);
            }
        frontier = std::move(next);
      }
      for (int a : reached) {
        if (a != start) excluded[start].push_back(a);
        distance[a] = -1;
      }
    }
    for (auto [i, j] : m.explicit_exclusions) {
      if (i == j) continue;
      excluded[i].push_back(j);
      excluded[j].push_back(i);
    }
    for (auto& list : excluded) {
      std::sort(list.begin(), list.end());
      list.erase(std::unique(list.begin(), list.end()), list.end());
    }
    return excluded;
  }

  std::pair<double, double> lennard_jones(const AtomType& a, const AtomType& b) const {
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

  // GROMACS renumbers the residues of single-residue molecules (water, ions) consecutively after
  // the highest residue number of the other molecules; multi-residue molecules keep theirs.
  static int residue_count(const MoleculeType& m) {
    int count = 0;
    for (std::size_t a = 0; a < m.atoms.size(); ++a)
      if (a == 0 || m.atoms[a].residue_number != m.atoms[a - 1].residue_number) ++count;
    return count;
  }

  template <class Dihedral>
  static void append_shifted(const std::vector<Dihedral>& from, int offset, std::vector<Dihedral>& to) {
    for (Dihedral d : from) {
      d.i += offset;
      d.j += offset;
      d.k += offset;
      d.l += offset;
      to.push_back(d);
    }
  }

  System build() const {
    System system;
    system.title = title_;
    std::size_t n = 0;
    int next_residue = 1;
    for (const auto& mc : molecule_counts_) {
      const MoleculeType& m = molecules_[mc.type];
      n += m.atoms.size() * mc.count;
      if (residue_count(m) > 1)
        for (const auto& a : m.atoms) next_residue = std::max(next_residue, a.residue_number + 1);
    }
    system.mass.resize(n);
    system.charge.resize(n);
    system.exclusions.reserve(n);
    std::vector<int> compact_type(atomtypes_.size(), -1);
    std::vector<int> used_types;

    int offset = 0, instance = 0;
    for (const auto& mc : molecule_counts_) {
      const MoleculeType& m = molecules_[mc.type];
      const auto excluded = molecule_exclusions(m);
      const auto sites = construction_order(m);
      const bool renumber = residue_count(m) <= 1;
      for (int copy = 0; copy < mc.count; ++copy, ++instance) {
        for (std::size_t a = 0; a < m.atoms.size(); ++a) {
          const MoleculeAtom& atom = m.atoms[a];
          if (compact_type[atom.type] < 0) {
            compact_type[atom.type] = static_cast<int>(used_types.size());
            used_types.push_back(atom.type);
          }
          const int global = offset + static_cast<int>(a);
          system.atom_names.push_back(atom.name);
          system.residue_names.push_back(atom.residue_name);
          system.residue_numbers.push_back(renumber ? next_residue : atom.residue_number);
          system.molecule.push_back(instance);
          system.mass[global] = atom.mass;
          system.charge[global] = atom.charge;
          system.type.push_back(compact_type[atom.type]);
          std::vector<int> list = excluded[a];
          for (int& e : list) e += offset;
          system.exclusions.push_back(std::move(list));
        }
        if (renumber) ++next_residue;
        for (Bond b : m.bonds) {
          b.i += offset;
          b.j += offset;
          system.bonds.push_back(b);
        }
        for (Angle a : m.angles) {
          a.i += offset;
          a.j += offset;
          a.k += offset;
          system.angles.push_back(a);
        }
        append_shifted(m.proper_dihedrals, offset, system.proper_dihedrals);
        append_shifted(m.periodic_impropers, offset, system.periodic_impropers);
        append_shifted(m.rb_dihedrals, offset, system.rb_dihedrals);
        append_shifted(m.harmonic_impropers, offset, system.harmonic_impropers);
        for (Pair14 p : m.pairs14) {
          p.i += offset;
          p.j += offset;
          system.pairs14.push_back(p);
        }
        for (Constraint c : m.constraints) {
          c.i += offset;
          c.j += offset;
          system.constraints.push_back(c);
        }
        system.bonds_constrained += m.bonds_constrained;
        for (SiteLine line : sites) {
          VirtualSite& v = line.site;
          v.site += offset;
          v.i += offset;
          v.j += offset;
          if (v.k >= 0) v.k += offset;
          system.virtual_sites.push_back(v);
        }
        offset += static_cast<int>(m.atoms.size());
      }
    }

    const int nt = static_cast<int>(used_types.size());
    system.c6.resize(nt, nt);
    system.c12.resize(nt, nt);
    for (int a = 0; a < nt; ++a) {
      system.type_names.push_back(atomtypes_[used_types[a]].name);
      for (int b = 0; b < nt; ++b)
        std::tie(system.c6(a, b), system.c12(a, b)) = lennard_jones(atomtypes_[used_types[a]], atomtypes_[used_types[b]]);
    }
    return system;
  }

  fs::path top_;
  Preprocessor pre_;
  std::string section_name_;
  std::optional<SectionInfo> section_;

  BondConstraints bond_constraints_;
  std::optional<int> comb_rule_;
  Where defaults_where_;
  bool gen_pairs_ = false;
  double fudge_lj_ = 1, fudge_qq_ = 1;
  std::set<std::string> bonded_names_;
  std::map<std::pair<std::string, std::string>, std::pair<std::pair<double, double>, Where>> pairtypes_;
  std::map<int, std::vector<DihedralType>> dihedraltypes_;  // by DihedralFunction::table
  std::vector<AtomType> atomtypes_;
  std::unordered_map<std::string, int> atomtype_index_;
  std::map<std::pair<std::string, std::string>, std::pair<std::pair<double, double>, Where>> nonbond_params_;
  std::map<std::pair<std::string, std::string>, std::pair<std::pair<double, double>, Where>> bondtypes_;
  std::map<std::pair<int, std::pair<std::string, std::string>>, std::pair<double, Where>> constrainttypes_;
  std::map<std::array<std::string, 3>, std::pair<std::pair<double, double>, Where>> angletypes_;
  std::vector<MoleculeType> molecules_;
  std::vector<MoleculeCount> molecule_counts_;
  long total_atoms_ = 0;
  std::string title_;
};

}  // namespace

std::vector<fs::path> gromacs_library_dirs() {
  std::vector<fs::path> dirs;
  const char* gmxlib = std::getenv("GMXLIB");
  if (gmxlib && *gmxlib) {
    std::string_view rest(gmxlib);
    while (!rest.empty()) {
      const auto colon = std::min(rest.find(':'), rest.size());
      if (colon > 0) dirs.emplace_back(rest.substr(0, colon));
      rest.remove_prefix(std::min(colon + 1, rest.size()));
    }
  } else {
    dirs.emplace_back("/usr/share/gromacs/top");
  }
  return dirs;
}

bool hydrogen_like(const std::string& atom_name) {
  return !atom_name.empty() && std::toupper(static_cast<unsigned char>(atom_name[0])) == 'H';
}

System read_topology(const fs::path& top, BondConstraints bond_constraints) {
  return TopologyParser(top, bond_constraints).parse();
}

}  // namespace vimd
