#pragma once
// The base of the bonded terms (bonds, angles, dihedrals, 1–4 pairs): a term with its own list of
// interactions writes its forces and its Hessian–vector product once, on a BondedLoop it is
// given; this base runs them on its own loop, and add_single_point on a fresh one.
#include <span>

#include "engine/force_field.hpp"
#include "forcefields/bonded_loop.hpp"

namespace vimd {

class BondedTerm : public ForceTerm {
 public:
  void add_forces(const Coords& q, Coords& f, std::span<double> energies, const TermEvaluation& = {}) final {
    add_forces_with(loop_, q, f, energies);
  }
  void add_hessian_vector(const Coords& q, const Coords& u, Coords& out, const TermEvaluation& = {}) final {
    add_hessian_vector_with(loop_, q, u, out);
  }
  void add_single_point(const Coords& q, Coords& f, std::span<double> energies) const final {
    BondedLoop loop;
    add_forces_with(loop, q, f, energies);
  }

 protected:
  // Adds −∇V to f and the term's energies to energies (empty: forces only).
  virtual void add_forces_with(BondedLoop& loop, const Coords& q, Coords& f, std::span<double> energies) const = 0;
  // Adds ∇²V(q) u to out.
  virtual void add_hessian_vector_with(BondedLoop& loop, const Coords& q, const Coords& u, Coords& out) const = 0;

 private:
  BondedLoop loop_;
};

}  // namespace vimd
