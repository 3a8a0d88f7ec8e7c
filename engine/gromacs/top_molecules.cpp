#include "engine/gromacs/top_molecules.hpp"

#include <algorithm>
#include <array>
#include <cctype>
#include <charconv>
#include <cmath>
#include <map>
#include <numbers>
#include <optional>

namespace vimd::top {

namespace {

// Residue numbers may carry an insertion code, e.g. 12A.
int residue_number(const Fields& f, std::size_t k) {
  const std::string& s = f[k];
  int value = 0;
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), value);
  const std::size_t rest = s.data() + s.size() - end;
  if (ec != std::errc() || rest > 1 || (rest == 1 && !std::isalpha(static_cast<unsigned char>(*end))))
    f.error("[ atoms ] field " + std::to_string(k + 1) + " (residue number) is not an integer: '" + s + "'");
  return value;
}

// Inline parameters: `n` A-state values, optionally followed by an identical B state.
std::optional<std::vector<double>> inline_parameters(const Fields& f, std::size_t first, std::size_t n,
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

std::string describe(const MoleculeType& molecule, int atom) {
  return std::to_string(atom + 1) + " (" + molecule.atoms[atom].name + ")";
}

}  // namespace

void MoleculeTypeReader::moleculetype(const Fields& f) {
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

void MoleculeTypeReader::atom(const Fields& f) {
  f.require(5, "nr type resnr residue atom [cgnr charge mass]");
  MoleculeType& molecule = molecules_.back();
  const long nr = f.integer(0, "atom number");
  if (nr != static_cast<long>(molecule.atoms.size()) + 1)
    f.error("atoms must be numbered consecutively: expected " + std::to_string(molecule.atoms.size() + 1) +
            ", found " + f[0]);
  const AtomType& type = parameters_.atomtype_named(f, 1);
  MoleculeAtom a{parameters_.index_of(type), residue_number(f, 2), f[3], f[4],
                 f.size() > 6 ? f.number(6, "charge") : type.charge, f.size() > 7 ? f.number(7, "mass") : type.mass,
                 type.ptype, f.where()};
  if (f.size() > 8) {
    const AtomType& type_b = parameters_.atomtype_named(f, 8);
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

void MoleculeTypeReader::bond(const Fields& f) {
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
  if (!params) params = parameters_.bond_parameters(f, bonded_name(molecule, i), bonded_name(molecule, j));
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

void MoleculeTypeReader::angle(const Fields& f) {
  f.require(4, "ai aj ak func [parameters]");
  MoleculeType& molecule = molecules_.back();
  const int i = f.atom(0, molecule), j = f.atom(1, molecule), k = f.atom(2, molecule);
  if (i == j || j == k || i == k) f.error("angle with a repeated atom");
  if (f.integer(3, "func") != 1) {
    molecule.mark_unsupported(f.where(), "angle function type " + f[3] + " is not supported (only 1, harmonic)");
    return;
  }
  auto params = inline_parameters(f, 4, 2, "theta0 k", molecule);
  if (!params)
    params = parameters_.angle_parameters(f, bonded_name(molecule, i), bonded_name(molecule, j),
                                          bonded_name(molecule, k));
  molecule.angles.push_back({i, j, k, (*params)[0] * std::numbers::pi / 180.0, (*params)[1]});
}

void MoleculeTypeReader::dihedral(const Fields& f) {
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
    for (const DihedralType* type : parameters_.find_dihedraltypes(function->table, names)) {
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

// A 1–4 pair's LJ: its own parameters, else the force field's (pair14_lennard_jones).
void MoleculeTypeReader::pair(const Fields& f) {
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
  const auto params = inline_parameters(f, 3, 2, "V W", molecule);
  const auto& types = parameters_.atomtypes();
  const auto [c6, c12] = params ? parameters_.lj_coefficients((*params)[0], (*params)[1])
                                : parameters_.pair14_lennard_jones(f, types[molecule.atoms[i].type],
                                                                   types[molecule.atoms[j].type]);
  molecule.pairs14.push_back(
      {i, j, c6, c12, parameters_.fudge_qq() * molecule.atoms[i].charge * molecule.atoms[j].charge});
}

void MoleculeTypeReader::constraint(const Fields& f) {
  f.require(3, "ai aj func [b0]");
  MoleculeType& molecule = molecules_.back();
  const int i = f.atom(0, molecule), j = f.atom(1, molecule);
  if (i == j) f.error("constraint between an atom and itself");
  const long func = f.integer(2, "func");
  if (func != 1 && func != 2) f.error("constraint function type " + f[2] + " does not exist (1 or 2)");
  auto params = inline_parameters(f, 3, 1, "b0", molecule);
  if (!params) params = parameters_.constraint_parameters(f, func, bonded_name(molecule, i), bonded_name(molecule, j));
  if ((*params)[0] <= 0) f.error("constraint length must be positive");
  molecule.constraints.push_back({i, j, (*params)[0]});
  molecule.constraint_lines.push_back(f.where());
  if (func == 1) molecule.chemical_bonds.emplace_back(i, j);  // type 2 generates no exclusions
}

// A settle is rigid water: oxygen `ow`, hydrogens ow+1, ow+2; three distance constraints. As in
// grompp, it is no chemical bond: its pairs are excluded only by [ exclusions ] (GROMACS's water
// models list them there); without, they interact (a constant energy in the rigid molecule).
void MoleculeTypeReader::settle(const Fields& f) {
  f.require(4, "OW funct doh dhh");
  if (f.size() > 4)
    f.error("settles takes OW funct doh dhh: found " + std::to_string(f.size() - 2) +
            " parameters after the function type, expected 2 (as grompp)");
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
  molecule.settles.emplace_back(o, f.where());
}

void MoleculeTypeReader::exclusion(const Fields& f) {
  f.require(2, "ai aj [ak …]");
  MoleculeType& molecule = molecules_.back();
  const int i = f.atom(0, molecule);
  for (std::size_t k = 1; k < f.size(); ++k) molecule.explicit_exclusions.emplace_back(i, f.atom(k, molecule));
}

// "site ai aj [ak] func parameters", as grompp reads [ virtual_sites2 ] (functions 1 "2", 2 "2fd")
// and [ virtual_sites3 ] (1 "3", 2 "3fd", 3 "3fad" with theta in degrees, 4 "3out").
void MoleculeTypeReader::virtual_site(const Fields& f, int from) {
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
    f.error("[ " + f.section() + " ] function type " + f[func_field] + " does not exist (" +
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
  molecule.sites.push_back({v, f.where()});
}

}  // namespace vimd::top
