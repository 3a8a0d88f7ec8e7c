#pragma once
// 1–4 pair interactions (GROMACS [ pairs ] function 1), energies "lj14" and "coulomb14"
// (GROMACS's LJ-14 and Coulomb-14), without cut-off, differences by minimum image:
//   V_lj14 = c12/r¹² − c6/r⁶  (the pair's c6, c12: [ pairtypes ], or generated with fudgeLJ)
//   V_coulomb14 = fudgeQQ f qi qj/(ε_r r),  f = 138.935458 kJ/mol nm e⁻²
// As in GROMACS the Coulomb factor is f/ε_r whatever the long-range method (epsilon_rf plays no
// part); with coulomb = "none" there is no electrostatics at all, 1–4 pairs included.
#include <vector>

#include "engine/box.hpp"
#include "forcefields/settings.hpp"
#include "engine/system.hpp"
#include "forcefields/bonded_term.hpp"

namespace vimd {

class Pair14Term : public BondedTerm {
 public:
  Pair14Term(std::vector<Pair14> pairs, const Box& box, const ForceFieldConfig& config);

  std::vector<std::string> energy_names() const override { return {"lj14", "coulomb14"}; }

 private:
  std::vector<Pair14> pairs_;
  Box box_;
  double coulomb_factor_;  // f/ε_r, or 0 without electrostatics

  void add_forces_with(BondedLoop& loop, const Coords& q, Coords& f, std::span<double> energies) const override;
  void add_hessian_vector_with(BondedLoop& loop, const Coords& q, const Coords& u, Coords& out) const override;
};

}  // namespace vimd
