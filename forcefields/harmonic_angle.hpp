#pragma once
// Harmonic angle bending (GROMACS angle type 1, harmonic in θ), energy "angles":
//   V = Σ_angles ½ k (θ_ijk − θ0)², θ = angle at the vertex j between r_i − r_j and r_k − r_j (minimum image)
//   Units: θ, θ0 rad; k kJ/mol/rad²; V kJ/mol.
#include <vector>

#include "engine/box.hpp"
#include "engine/system.hpp"
#include "forcefields/bonded_term.hpp"

namespace vimd {

class HarmonicAngleTerm : public BondedTerm {
 public:
  HarmonicAngleTerm(std::vector<Angle> angles, const Box& box);

  std::vector<std::string> energy_names() const override { return {"angles"}; }

 private:
  std::vector<Angle> angles_;
  Box box_;
  void add_forces_with(BondedLoop& loop, const Coords& q, Coords& f, std::span<double> energies) const override;
  void add_hessian_vector_with(BondedLoop& loop, const Coords& q, const Coords& u, Coords& out) const override;
};

}  // namespace vimd
