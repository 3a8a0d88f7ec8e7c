#pragma once
// The potential as a sum of terms. Forces are functions of positions only (RK stages are not
// States). Every term provides energy, forces and a Hessian–vector product.
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "engine/carried.hpp"
#include "engine/types.hpp"

namespace vimd {

struct Forces {
  Coords f;                   // kJ/mol/nm
  double potential = 0;       // kJ/mol
  std::vector<double> terms;  // kJ/mol, aligned with ForceField::energy_names()
};

class ForceTerm {
 public:
  virtual ~ForceTerm() = default;
  // Names of the energies this term reports, e.g. {"lj", "coulomb"} for the nonbonded pair term.
  virtual std::vector<std::string> energy_names() const = 0;
  // Adds −∇V to f and the energies to energies[0..energy_names().size()).
  virtual void add_forces(const Coords& q, Coords& f, std::span<double> energies) = 0;
  // Adds ∇²V(q) u to out.
  virtual void add_hessian_vector(const Coords& q, const Coords& u, Coords& out) = 0;
  // Terms with neighbour lists keep them valid for q here (rebuilding when needed); the
  // ForceField calls this before every evaluation, so no pair inside the cut-off is missed.
  virtual void prepare(const Coords& /*q*/) {}
  virtual long rebuilds() const { return 0; }
  // Checkpoints: what changes results at round-off besides q (the neighbour list's build
  // positions: the list's order is the summation order), and rebuilding from it.
  virtual void save(Carried& /*out*/) const {}
  virtual void restore(const Carried& /*in*/) {}
};

class ForceField {
 public:
  void add(std::unique_ptr<ForceTerm> term);
  const std::vector<std::string>& energy_names() const { return names_; }

  void compute(const Coords& q, Forces& out);
  // out = ∇²V(q) u
  void hessian_vector(const Coords& q, const Coords& u, Coords& out);

  // Work counters, for cost reports (force-evaluation equivalents).
  long force_evaluations() const { return force_evaluations_; }
  long hessian_evaluations() const { return hessian_evaluations_; }
  long neighbor_rebuilds() const;
  // Every term's save()/restore(), entries prefixed with the term's index.
  Carried save() const;
  void restore(const Carried& in);

  const std::vector<std::unique_ptr<ForceTerm>>& terms() const { return terms_; }

 private:
  std::vector<std::unique_ptr<ForceTerm>> terms_;
  std::vector<std::string> names_;
  std::vector<std::size_t> name_counts_;  // per term
  long force_evaluations_ = 0;
  long hessian_evaluations_ = 0;
};

}  // namespace vimd
