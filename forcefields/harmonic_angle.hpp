#pragma once
// Harmonic angle bending (GROMACS angle type 1, harmonic in θ), energy "angles":
//   V = Σ_angles ½ k (θ_ijk − θ0)², θ = angle at the vertex j between r_i − r_j and r_k − r_j (minimum image)
//   Units: θ, θ0 rad; k kJ/mol/rad²; V kJ/mol.
#include <vector>

#include "engine/box.hpp"
#include "engine/force_field.hpp"
#include "engine/system.hpp"
#include "forcefields/bonded_loop.hpp"

namespace vimd {

class HarmonicAngleTerm : public ForceTerm {
 public:
  HarmonicAngleTerm(std::vector<Angle> angles, const Box& box);

  std::vector<std::string> energy_names() const override { return {"angles"}; }
  void add_forces(const Coords& q, Coords& f, std::span<double> energies) override;
  void add_hessian_vector(const Coords& q, const Coords& u, Coords& out) override;

 private:
  std::vector<Angle> angles_;
  Box box_;
  BondedLoop loop_;
};

}  // namespace vimd
