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
  void add_forces(const Coords& q, Coords& f, std::span<double> energies, const TermEvaluation& = {}) override {
    add_forces(loop_, q, f, energies);
  }
  void add_hessian_vector(const Coords& q, const Coords& u, Coords& out, const TermEvaluation& = {}) override;
  void add_single_point(const Coords& q, Coords& f, std::span<double> energies) const override {
    BondedLoop loop;
    add_forces(loop, q, f, energies);
  }

 private:
  std::vector<Angle> angles_;
  Box box_;
  void add_forces(BondedLoop& loop, const Coords& q, Coords& f, std::span<double> energies) const;

  BondedLoop loop_;
};

}  // namespace vimd
