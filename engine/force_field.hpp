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
  // Adds −∇V to f and the energies to energies[0..energy_names().size()); an empty `energies`
  // asks for the forces only (a term may then skip the energy work).
  virtual void add_forces(const Coords& q, Coords& f, std::span<double> energies) = 0;
  // Adds ∇²V(q) u to out.
  virtual void add_hessian_vector(const Coords& q, const Coords& u, Coords& out) = 0;
  // Terms with neighbour lists keep them valid for q here (rebuilding when needed); the
  // ForceField calls this before every evaluation, so no pair inside the cut-off is missed.
  virtual void prepare(const Coords& /*q*/) {}
  // Where the force jumps at the cut-off: fixes which pairs interact to those inside it at *q, until
  // called with nullptr; every evaluation in between includes exactly these pairs, wherever they
  // move (each pair potential continued smoothly past the cut-off), and no others, so a crossing
  // cannot make the force jump between evaluations. Where the force is continuous there, the
  // potential stays the truncated one, smooth enough and exact (see ForceField::fix_pair_set).
  // Either way the evaluations in between are one step's, near *q: a term may visit a list cut to
  // them (NonbondedPairTerm's step list), with the same results.
  virtual void fix_pair_set(const Coords* /*q*/) {}
  // Whether the term has single-precision kernels, and using them for forces and Hessian–vector
  // products until called with false: for the parts of a solve whose rounding the solve absorbs
  // (VariationalSettings::mixed_precision_solve).
  virtual bool has_single_precision() const { return false; }
  virtual void set_single_precision(bool /*on*/) {}
  virtual long rebuilds() const { return 0; }
  virtual long prunes() const { return 0; }
  virtual double rebuild_seconds() const { return 0; }
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
  // The forces alone (the pair kernels skip the energy sums): out.potential and out.terms are NaN,
  // so that a use of energies nobody computed shows.
  void compute_forces(const Coords& q, Forces& out);
  // out = ∇²V(q) u
  void hessian_vector(const Coords& q, const Coords& u, Coords& out);
  // Freezes the interacting pair set at q (nullptr releases it) of every term whose force jumps at
  // the cut-off. Between the two calls its potential is V_q̂(x) = Σ over the pairs inside the
  // cut-off at q̂ of the pair potentials, each continued analytically beyond the cut-off: a smooth
  // function of x, which the variational integrator uses as one step's potential so that its step
  // equations are smooth. A term whose force is continuous at the cut-off keeps its true truncated
  // potential: the solve converges on it, and the continuation would cost energy conservation
  // (on water900, switched LJ + reaction field eps_rf = inf, vi rk4: 10x the RMS energy fluctuation).
  void fix_pair_set(const Coords* q);
  // Every term with a single-precision path uses it until called with false (ForceTerm::set_single_precision).
  void set_single_precision(bool on);
  bool has_single_precision() const;

  // Work counters, for cost reports (force-evaluation equivalents), and how many of them some term
  // computed in single precision.
  long force_evaluations() const { return force_evaluations_; }
  long hessian_evaluations() const { return hessian_evaluations_; }
  long single_precision_force_evaluations() const { return single_force_evaluations_; }
  long single_precision_hessian_evaluations() const { return single_hessian_evaluations_; }
  long neighbor_rebuilds() const;
  long neighbor_prunes() const;
  double neighbor_build_seconds() const;
  // Every term's save()/restore(), entries prefixed with the term's index.
  Carried save() const;
  void restore(const Carried& in);

  const std::vector<std::unique_ptr<ForceTerm>>& terms() const { return terms_; }

 private:
  void evaluate(const Coords& q, Forces& out, bool energies);

  std::vector<std::unique_ptr<ForceTerm>> terms_;
  std::vector<std::string> names_;
  std::vector<std::size_t> name_counts_;  // per term
  long force_evaluations_ = 0;
  long hessian_evaluations_ = 0;
  bool single_precision_ = false;  // some term is in single precision now
  long single_force_evaluations_ = 0;
  long single_hessian_evaluations_ = 0;
};

// Single-precision pair arithmetic in `field` (where `on`) for the lifetime of the object.
class SinglePrecisionScope {
 public:
  SinglePrecisionScope(ForceField& field, bool on) : field_(field), on_(on) {
    if (on_) field_.set_single_precision(true);
  }
  ~SinglePrecisionScope() {
    if (on_) field_.set_single_precision(false);
  }
  SinglePrecisionScope(const SinglePrecisionScope&) = delete;
  SinglePrecisionScope& operator=(const SinglePrecisionScope&) = delete;

 private:
  ForceField& field_;
  bool on_;
};

// Fixes the pair set of `field` at q for the lifetime of the object (one variational step).
class FixedPairSet {
 public:
  FixedPairSet(ForceField& field, const Coords& q) : field_(field) { field_.fix_pair_set(&q); }
  ~FixedPairSet() { field_.fix_pair_set(nullptr); }
  FixedPairSet(const FixedPairSet&) = delete;
  FixedPairSet& operator=(const FixedPairSet&) = delete;

 private:
  ForceField& field_;
};

}  // namespace vimd
