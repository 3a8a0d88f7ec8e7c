#include "engine/gromacs/top_assembly.hpp"

#include <algorithm>
#include <optional>
#include <tuple>

#include "engine/gromacs/top_checks.hpp"

namespace vimd::top {

namespace {

// Per atom of a molecule type: the atoms within nrexcl chemical bonds plus [ exclusions ].
std::vector<std::vector<int>> molecule_exclusions(const MoleculeType& m) {
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

// A settle's pairs interact unless [ exclusions ] lists them (settles are no chemical bonds for
// nrexcl in grompp): as gmx mdrun computes it, but rarely meant.
std::optional<std::string> settles_warning(const MoleculeType& m, const std::vector<std::vector<int>>& excluded) {
  for (const auto& [o, where] : m.settles) {
    const std::pair<int, int> pairs[] = {{o, o + 1}, {o, o + 2}, {o + 1, o + 2}};
    std::string missing;
    for (auto [i, j] : pairs)
      if (!std::binary_search(excluded[i].begin(), excluded[i].end(), j))
        missing += (missing.empty() ? "" : ", ") + std::to_string(i + 1) + "-" + std::to_string(j + 1);
    if (!missing.empty())
      return where.str() + ": the settled pairs " + missing + " of molecule type '" + m.name +
             "' are not in [ exclusions ]: as in grompp, settles exclude nothing themselves, so these pairs " +
             "interact (a constant Coulomb and LJ energy within the rigid molecule, as gmx mdrun computes it); " +
             "GROMACS's water models list them under [ exclusions ]";
  }
  return std::nullopt;
}

// GROMACS renumbers the residues of single-residue molecules (water, ions) consecutively after
// the highest residue number of the other molecules; multi-residue molecules keep theirs.
int residue_count(const MoleculeType& m) {
  int count = 0;
  for (std::size_t a = 0; a < m.atoms.size(); ++a)
    if (a == 0 || m.atoms[a].residue_number != m.atoms[a - 1].residue_number) ++count;
  return count;
}

int first_renumbered_residue(const std::vector<MoleculeType>& molecules, const std::vector<MoleculeCount>& counts) {
  int next_residue = 1;
  for (const auto& mc : counts) {
    const MoleculeType& m = molecules[mc.type];
    if (residue_count(m) > 1)
      for (const auto& a : m.atoms) next_residue = std::max(next_residue, a.residue_number + 1);
  }
  return next_residue;
}

// An interaction of one molecule copy: its atom indices shifted by the copy's first atom.
void shift(Bond& x, int offset) { x.i += offset, x.j += offset; }
void shift(Pair14& x, int offset) { x.i += offset, x.j += offset; }
void shift(Constraint& x, int offset) { x.i += offset, x.j += offset; }
void shift(Angle& x, int offset) { x.i += offset, x.j += offset, x.k += offset; }
template <class Dihedral>
void shift(Dihedral& x, int offset) {
  x.i += offset, x.j += offset, x.k += offset, x.l += offset;
}
void shift(VirtualSite& x, int offset) {
  x.site += offset, x.i += offset, x.j += offset;
  if (x.k >= 0) x.k += offset;
}

template <class Interaction>
void append_shifted(const std::vector<Interaction>& from, int offset, std::vector<Interaction>& to) {
  for (Interaction x : from) {
    shift(x, offset);
    to.push_back(x);
  }
}

// The atom types the system uses, numbered in order of first use.
struct UsedAtomTypes {
  std::vector<int> compact;  // per force-field type: its number here, or -1
  std::vector<int> types;    // per number: the force-field type

  int number(int type) {
    if (compact[type] < 0) {
      compact[type] = static_cast<int>(types.size());
      types.push_back(type);
    }
    return compact[type];
  }
};

// One copy's atoms, from atom `offset` on; `residue`, when given, replaces their residue numbers.
void append_atoms(const MoleculeType& m, const std::vector<std::vector<int>>& excluded, int offset, int instance,
                  std::optional<int> residue, UsedAtomTypes& used, System& system) {
  for (std::size_t a = 0; a < m.atoms.size(); ++a) {
    const MoleculeAtom& atom = m.atoms[a];
    const int type = used.number(atom.type);
    const int global = offset + static_cast<int>(a);
    system.atom_names.push_back(atom.name);
    system.residue_names.push_back(atom.residue_name);
    system.residue_numbers.push_back(residue.value_or(atom.residue_number));
    system.molecule.push_back(instance);
    system.mass[global] = atom.mass;
    system.charge[global] = atom.charge;
    system.type.push_back(type);
    std::vector<int> list = excluded[a];
    for (int& e : list) e += offset;
    system.exclusions.push_back(std::move(list));
  }
}

// One copy's interactions and virtual sites (in construction order), from atom `offset` on.
void append_interactions(const MoleculeType& m, const std::vector<SiteLine>& sites, int offset, System& system) {
  append_shifted(m.bonds, offset, system.bonds);
  append_shifted(m.angles, offset, system.angles);
  append_shifted(m.proper_dihedrals, offset, system.proper_dihedrals);
  append_shifted(m.periodic_impropers, offset, system.periodic_impropers);
  append_shifted(m.rb_dihedrals, offset, system.rb_dihedrals);
  append_shifted(m.harmonic_impropers, offset, system.harmonic_impropers);
  append_shifted(m.pairs14, offset, system.pairs14);
  append_shifted(m.constraints, offset, system.constraints);
  system.bonds_constrained += m.bonds_constrained;
  for (SiteLine line : sites) {
    shift(line.site, offset);
    system.virtual_sites.push_back(line.site);
  }
}

void set_lennard_jones_tables(const UsedAtomTypes& used, const ForceFieldParameters& parameters, System& system) {
  const auto& atomtypes = parameters.atomtypes();
  const int nt = static_cast<int>(used.types.size());
  system.c6.resize(nt, nt);
  system.c12.resize(nt, nt);
  for (int a = 0; a < nt; ++a) {
    system.type_names.push_back(atomtypes[used.types[a]].name);
    for (int b = 0; b < nt; ++b)
      std::tie(system.c6(a, b), system.c12(a, b)) =
          parameters.lennard_jones(atomtypes[used.types[a]], atomtypes[used.types[b]]);
  }
}

}  // namespace

System assemble_system(const std::vector<MoleculeType>& molecules, const std::vector<MoleculeCount>& counts,
                       const ForceFieldParameters& parameters, const std::string& title,
                       std::vector<std::string>& warnings) {
  System system;
  system.title = title;
  std::size_t n = 0;
  for (const auto& mc : counts) n += molecules[mc.type].atoms.size() * mc.count;
  system.mass.resize(n);
  system.charge.resize(n);
  system.exclusions.reserve(n);
  UsedAtomTypes used{std::vector<int>(parameters.atomtypes().size(), -1), {}};
  int next_residue = first_renumbered_residue(molecules, counts);
  int offset = 0, instance = 0;
  std::vector<bool> warned(molecules.size(), false);
  for (const auto& mc : counts) {
    const MoleculeType& m = molecules[mc.type];
    const auto excluded = molecule_exclusions(m);
    if (!warned[mc.type])
      if (auto warning = settles_warning(m, excluded)) warnings.push_back(std::move(*warning));
    warned[mc.type] = true;
    const auto sites = construction_order(m);
    const bool renumber = residue_count(m) <= 1;
    for (int copy = 0; copy < mc.count; ++copy, ++instance) {
      append_atoms(m, excluded, offset, instance, renumber ? std::optional(next_residue++) : std::nullopt, used, system);
      append_interactions(m, sites, offset, system);
      offset += static_cast<int>(m.atoms.size());
    }
  }
  set_lennard_jones_tables(used, parameters, system);
  return system;
}

}  // namespace vimd::top
