#pragma once
// The standard layer: a one-step method Φ_τ for y = (q, v, S) with q' = v, v' = A(q,v),
// S' = L(q,v), S(0) = 0, over a signed time τ; a forward pass that keeps its stages, and the
// vector–Jacobian product (discrete adjoint) ȳ₁·DΦ_τ(q, v) (docs/variational-integrator.md,
// "The one-step method and its adjoint").
#include <memory>
#include <string>
#include <vector>

#include "integrators/constrained_dynamics.hpp"
#include "integrators/tableau.hpp"

namespace vimd {

// One forward pass: its outputs and what the reverse pass needs. Reused across passes, so the
// second and later passes of the same size do not allocate.
struct Segment {
  double tau = 0;
  Coords q, v;       // Q_τ(q₀, v₀), V_τ(q₀, v₀)
  double action = 0; // S_τ(q₀, v₀)
  std::vector<DynamicsPoint> stages;
};

class OneStepMethod {
 public:
  virtual ~OneStepMethod() = default;
  virtual std::string name() const = 0;
  virtual int order() const = 0;
  // Force evaluations per forward pass.
  virtual int stages() const = 0;
  // Φ_τ(q, v) into seg. `forces_at_q`, when known, saves the first evaluation.
  virtual void forward(ConstrainedDynamics& dynamics, const Coords& q, const Coords& v, double tau, Segment& seg,
                       const Forces* forces_at_q = nullptr, const DynamicsPrecision& precision = {}) = 0;
  // (q_bar, v_bar) = (Q̄, V̄, S̄)·DΦ_τ at the segment's start; V̄ = 0 when v_seed is null.
  // Overwrites q_bar and v_bar. With `start_hvp` given, the Hessian–vector product at the start
  // point is deferred: its direction is added to *start_hvp and −∇²V(q₀)·(*start_hvp) is left for
  // the caller to subtract from q_bar (one product for several segments starting at q₀).
  virtual void vjp(ConstrainedDynamics& dynamics, const Segment& seg, const Coords& q_seed, const Coords* v_seed,
                   double s_seed, Coords& q_bar, Coords& v_bar, Coords* start_hvp = nullptr,
                   const DynamicsPrecision& precision = {}) = 0;
};

class ExplicitRungeKutta : public OneStepMethod {
 public:
  explicit ExplicitRungeKutta(ButcherTableau tableau);
  std::string name() const override { return tableau_.name; }
  int order() const override { return tableau_.order; }
  int stages() const override { return tableau_.stages(); }
  const ButcherTableau& tableau() const { return tableau_; }

  void forward(ConstrainedDynamics& dynamics, const Coords& q, const Coords& v, double tau, Segment& seg,
               const Forces* forces_at_q = nullptr, const DynamicsPrecision& precision = {}) override;
  // Discrete adjoint, k = s..1: K̄_k = τ(b_k ȳ₁ + Σ_{j>k} a_jk Ȳ_j), Ȳ_k = K̄_k·DF(Y_k), ȳ₀ = ȳ₁ + Σ_k Ȳ_k,
  // with Ȳ_q = k̄_v·∂A/∂q + k̄_S f and Ȳ_v = k̄_q + k̄_v·∂A/∂v + k̄_S M v. A stage whose k̄_v is
  // structurally zero (the last one when V̄ = 0) costs no Hessian–vector product.
  void vjp(ConstrainedDynamics& dynamics, const Segment& seg, const Coords& q_seed, const Coords* v_seed,
           double s_seed, Coords& q_bar, Coords& v_bar, Coords* start_hvp = nullptr,
           const DynamicsPrecision& precision = {}) override;

 private:
  ButcherTableau tableau_;
  std::vector<Coords> stage_q_bar_, stage_v_bar_;  // Ȳ_k
  Coords k_q_bar_, k_v_bar_;                        // K̄_k
  Coords stage_q_, stage_v_;                        // Y_k in the forward pass
};

std::unique_ptr<OneStepMethod> make_one_step_method(const ButcherTableau& tableau);

}  // namespace vimd
