#pragma once
// Harmonic bond stretching (GROMACS bond type 1), energy "bonds":
//   V = Σ_bonds ½ k (|r_i − r_j| − b0)², differences by minimum image
//   Units: r, b0 nm; k kJ/mol/nm²; V kJ/mol.
#include <vector>

#include "engine/box.hpp"
#include "engine/force_field.hpp"
#include "engine/system.hpp"
#include "forcefields/bonded_loop.hpp"

namespace vimd {

class HarmonicBondTerm : public ForceTerm {
 public:
  HarmonicBondTerm(std::vector<Bond> bonds, const Box& box);

  std::vector<std::string> energy_names() const override { return {"bonds"}; }
  void add_forces(const Coords& q, Coords& f, std::span<double> energies, const TermEvaluation& = {}) override {
    add_forces(loop_, q, f, energies);
  }
  void add_hessian_vector(const Coords& q, const Coords& u, Coords& out, const TermEvaluation& = {}) override;
  void add_single_point(const Coords& q, Coords& f, std::span<double> energies) const override {
    BondedLoop loop;
    add_forces(loop, q, f, energies);
  }

 private:
  std::vector<Bond> bonds_;
  Box box_;
  void add_forces(BondedLoop& loop, const Coords& q, Coords& f, std::span<double> energies) const;

  BondedLoop loop_;
};

}  // namespace vimd
