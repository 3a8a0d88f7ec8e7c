#include "engine/system_identity.hpp"

#include <string>
#include <tuple>
#include <type_traits>

#include "engine/config_schema.hpp"
#include "engine/fingerprint.hpp"

namespace vimd {
namespace {

// Each interaction's fields, unpacked by a structured binding: a field added to the struct breaks
// the build here until it is fingerprinted too.
auto fields(const Bond& x) {
  const auto& [i, j, length, k] = x;
  return std::tie(i, j, length, k);
}
auto fields(const Angle& x) {
  const auto& [i, j, k, theta0, force_constant] = x;
  return std::tie(i, j, k, theta0, force_constant);
}
auto fields(const PeriodicDihedral& x) {
  const auto& [i, j, k, l, phi_s, force_constant, multiplicity] = x;
  return std::tie(i, j, k, l, phi_s, force_constant, multiplicity);
}
auto fields(const HarmonicImproper& x) {
  const auto& [i, j, k, l, xi0, force_constant] = x;
  return std::tie(i, j, k, l, xi0, force_constant);
}
auto fields(const RyckaertBellemansDihedral& x) {
  const auto& [i, j, k, l, c] = x;
  return std::tie(i, j, k, l, c);
}
auto fields(const Pair14& x) {
  const auto& [i, j, c6, c12, qq] = x;
  return std::tie(i, j, c6, c12, qq);
}
auto fields(const Constraint& x) {
  const auto& [i, j, length] = x;
  return std::tie(i, j, length);
}
auto fields(const VirtualSite& x) {
  const auto& [kind, site, i, j, k, a, b, c] = x;
  return std::tie(kind, site, i, j, k, a, b, c);
}

// Field by field, never a struct's bytes (its padding is undefined); sizes included, so that moving
// an entry from one list to the next shows.
template <class T>
void add(Fingerprint& f, const T& x) {
  if constexpr (std::is_arithmetic_v<T> || std::is_enum_v<T>) {
    f.add(x);
  } else if constexpr (std::is_base_of_v<Eigen::DenseBase<T>, T>) {
    f.add(x.size());
    for (Eigen::Index k = 0; k < x.size(); ++k) f.add(x.data()[k]);
  } else if constexpr (requires { x.begin(); x.size(); }) {
    f.add(x.size());
    for (const auto& element : x) add(f, element);
  } else {
    std::apply([&](const auto&... field) { (add(f, field), ...); }, fields(x));
  }
}

template <class... Parts>
std::string described(std::size_t count, const char* what, const Parts&... parts) {
  Fingerprint f;
  (add(f, parts), ...);
  return std::to_string(count) + " " + what + ", fingerprint " + f.text();
}

std::size_t excluded_pairs(const std::vector<std::vector<int>>& exclusions) {
  std::size_t n = 0;
  for (const auto& excluded : exclusions) n += excluded.size();
  return n / 2;  // each pair is listed for both atoms
}

}  // namespace

RunIdentity system_identity(const System& s) {
  // Every member, so that one added to System breaks the build here until it is either part of the
  // identity or said not to be.
  const auto& [title, atom_names, residue_names, residue_numbers, molecule, mass, charge, type, type_names, c6, c12,
               bonds, angles, proper_dihedrals, rb_dihedrals, periodic_impropers, harmonic_impropers, pairs14,
               constraints, bonds_constrained, virtual_sites, exclusions, box] = s;
  (void)title;  // the structure file's comment line: nothing is computed with it
  const std::size_t atoms = mass.size();
  return {
      {"atoms", std::to_string(atoms)},
      {"system: atom, residue and type names", described(atoms, "atoms", atom_names, residue_names, residue_numbers,
                                                          type_names)},
      {"system: molecules", described(atoms, "atoms", molecule)},
      {"system: masses", described(atoms, "atoms", mass)},
      {"system: charges", described(atoms, "atoms", charge)},
      {"system: atom types and Lennard-Jones parameters", described(type_names.size(), "types", type, c6, c12)},
      {"system: bonds", described(bonds.size(), "bonds", bonds)},
      {"system: angles", described(angles.size(), "angles", angles)},
      {"system: dihedrals", described(proper_dihedrals.size() + rb_dihedrals.size(), "dihedrals", proper_dihedrals,
                                      rb_dihedrals)},
      {"system: impropers", described(periodic_impropers.size() + harmonic_impropers.size(), "impropers",
                                      periodic_impropers, harmonic_impropers)},
      {"system: 1-4 pairs", described(pairs14.size(), "pairs", pairs14)},
      {"system: constraints", described(constraints.size(), "constraints", constraints, bonds_constrained)},
      {"system: virtual sites", described(virtual_sites.size(), "sites", virtual_sites)},
      {"system: exclusions", described(excluded_pairs(exclusions), "excluded pairs", exclusions)},
      {"box", exact_text(box.length[0]) + " " + exact_text(box.length[1]) + " " + exact_text(box.length[2])}};
}

}  // namespace vimd
