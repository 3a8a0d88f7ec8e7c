#include "engine/gromacs/top_checks.hpp"

#include <algorithm>
#include <array>
#include <map>
#include <set>
#include <string>

#include "engine/gromacs/top_fields.hpp"

namespace vimd::top {

std::vector<SiteLine> construction_order(const MoleculeType& m) {
  std::vector<SiteLine> order = m.sites;
  std::stable_sort(order.begin(), order.end(),
                   [](const SiteLine& x, const SiteLine& y) { return x.site.kind < y.site.kind; });
  return order;
}

void check_sites(const MoleculeType& m) {
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

namespace {

// No atom pair constrained twice; the constraints by atom pair (i < j).
std::map<std::pair<int, int>, int> constraints_by_pair(const MoleculeType& m) {
  const auto& list = m.constraints;
  const auto& lines = m.constraint_lines;
  std::map<std::pair<int, int>, int> index;
  for (std::size_t a = 0; a < list.size(); ++a) {
    const auto [it, inserted] = index.try_emplace(std::minmax(list[a].i, list[a].j), static_cast<int>(a));
    if (!inserted)
      fail(lines[a], "atoms " + std::to_string(list[a].i + 1) + " and " + std::to_string(list[a].j + 1) +
                         " of molecule type '" + m.name + "' are constrained twice (first at " +
                         lines[it->second].str() + "): the constraint set is over-determined");
  }
  return index;
}

// No triangle of constraints that is flat or impossible.
void check_triangles(const MoleculeType& m, const std::map<std::pair<int, int>, int>& index) {
  const auto& list = m.constraints;
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
      fail(m.constraint_lines[last],
           "the constraints between atoms " + std::to_string(pair.first + 1) + ", " + std::to_string(pair.second + 1) +
               " and " + std::to_string(k + 1) + " of molecule type '" + m.name + "' form " +
               (d[2] > d[0] + d[1] ? "an impossible" : "a flat") + " triangle (" + format_number(d[0]) + " + " +
               format_number(d[1]) + " vs " + format_number(d[2]) +
               " nm): the three constraints are not independent (over-determined)");
    }
}

// No cluster of coupled constraints (union-find over atoms) with more than a rigid body's 3N − 6.
void check_clusters(const MoleculeType& m) {
  const auto& list = m.constraints;
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
    fail(m.constraint_lines[last[r]],
         std::to_string(count[r]) + " constraints join " + std::to_string(n) + " atoms (" +
             std::to_string(*members.begin() + 1) + ".." + std::to_string(*members.rbegin() + 1) +
             ") of molecule type '" + m.name + "', but a rigid body of " + std::to_string(n) + " atoms has only " +
             std::to_string(3 * n - 6) + " independent distances: the constraint set is over-determined");
  }
}

}  // namespace

void check_constraint_set(const MoleculeType& m) {
  check_triangles(m, constraints_by_pair(m));
  check_clusters(m);
}

}  // namespace vimd::top
