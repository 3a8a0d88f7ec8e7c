#pragma once
// Harmonic bond stretching (GROMACS bond type 1), energy "bonds":
//   V = Σ_bonds ½ k (|r_i − r_j| − b0)², differences by minimum image
//   Units: r, b0 nm; k kJ/mol/nm²; V kJ/mol.
#include <vector>

#include "engine/box.hpp"
#include "engine/system.hpp"
#include "forcefields/bonded_term.hpp"

namespace vimd {

class HarmonicBondTerm : public BondedTerm {
 public:
  HarmonicBondTerm(std::vector<Bond> bonds, const Box& box);

  std::vector<std::string> energy_names() const override { return {"bonds"}; }

 private:
  std::vector<Bond> bonds_;
  Box box_;
  void add_forces_with(BondedLoop& loop, const Coords& q, Coords& f, std::span<double> energies) const override;
  void add_hessian_vector_with(BondedLoop& loop, const Coords& q, const Coords& u, Coords& out) const override;
};

}  // namespace vimd
