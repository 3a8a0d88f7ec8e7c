#pragma once
// The checks a molecule type passes when [ molecules ] uses it, with grompp's rules: its virtual
// sites and masses, and the independence of its constraints. Each failure is an InputError at
// the line that breaks the rule.
#include <vector>

#include "engine/gromacs/top_model.hpp"

namespace vimd::top {

// grompp's construction order: by function (2, 2fd, 3, 3fd, 3fad, 3out), each in file order.
std::vector<SiteLine> construction_order(const MoleculeType& m);

// A site is constructed once, from atoms constructed before it, has mass 0 and no constraint;
// every other atom is a particle with a positive mass.
void check_sites(const MoleculeType& m);

// The constraints must be independent, or the constraint matrix G M⁻¹ Gᵀ is singular and no
// solver converges: no pair twice, no flat or impossible triangle, and no cluster of N atoms with
// more than the 3N − 6 distances a rigid body has.
void check_constraint_set(const MoleculeType& m);

}  // namespace vimd::top
