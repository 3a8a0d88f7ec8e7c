#pragma once
// The equations of one variational step (docs/variational-integrator.md, "Discrete Lagrangian" and
// "The step equations"). For w = (q, v) ∈ TQ, the segments ∂±(w) = P(Q_{τ±}(w)) with τ± = h α±,
// the discrete Lagrangian L_h(w) = S_{τ⁺}(w) − S_{τ⁻}(w), and momenta p± defined by
// DL_h = −p⁻·D∂⁻ + p⁺·D∂⁺ on T_w TQ. A step solves ∂⁻(w) = q̄, p⁻(w) = p̄ for (w, p⁺); this
// class evaluates the residual of those equations and the fixed-point map's corrections from the
// approximate Jacobian (q_τ ≈ q + τv, S_τ ≈ τL) ("Solving the step"). It holds no iterate: the
// solver passes (q, v, p⁺) in and keeps them.
#include <string>

#include "engine/integrator.hpp"
#include "integrators/constrained_dynamics.hpp"
#include "integrators/explicit_rk.hpp"
#include "integrators/projection.hpp"
#include "integrators/tableau.hpp"

namespace vimd {

class VariationalEquations {
 public:
  // `plus` and `minus` integrate the ∂⁺ and ∂⁻ segments; `projection` is "euclidean" or "mass".
  VariationalEquations(Problem& problem, const ButcherTableau& plus, const ButcherTableau& minus, double h,
                       double alpha_minus, double alpha_plus, const std::string& projection);

  // The vector field every segment evaluates.
  ConstrainedDynamics& dynamics() { return dynamics_; }

  // With α⁻ = 0, ∂⁻(w) = q: the position equation holds exactly with q = q̄, so q stays at q̄
  // through a step and the forces there are computed once.
  bool position_fixed() const { return alpha_minus_ == 0; }

  // The segments from w = (q, v): ∂⁺ always, ∂⁻ unless `plus_only` (and only where α⁻ ≠ 0).
  // `forces_at_q`, when given, must be the forces at exactly q.
  void evaluate_segments(const Coords& q, const Coords& v, long step, const Forces* forces_at_q = nullptr,
                         bool plus_only = false, const DynamicsPrecision& precision = {});
  // The ∂⁺ segment after w's velocity changed from v_before to v (q unchanged, α⁻ = 0), to first
  // order with the approximate Jacobian (∂Q⁺/∂v ≈ τ⁺, ∂V⁺/∂v ≈ 1): Q⁺ += τ⁺Δv, V⁺ += Δv,
  // x⁺ = P(Q⁺). For a solve's last update, Δv is small as the tolerance over the contraction
  // factor; the neglected terms, O((τ⁺)²(ω² + |∂A/∂v|))·τ⁺|Δv|, are then a few per cent of the
  // τ⁺·tolerance the solve leaves in x⁺ anyway, and the forward pass it replaces costs s − 1
  // force evaluations. The stages stay those of the last evaluation: only the first (at q, the
  // same) is read again.
  void advance_plus_segment_linearly(const Coords& v, const Coords& v_before, long step);
  // x± = ∂±(w) of the last evaluation (x⁻ = q where α⁻ = 0).
  const Coords& x_plus() const { return projected_plus_.x; }
  const Coords& x_minus(const Coords& q) const { return alpha_minus_ != 0 ? projected_minus_.x : q; }
  // The ∂⁺ segment (its end velocity V⁺ and its first stage's forces, those at w's q).
  const Segment& plus_segment() const { return plus_segment_; }
  Segment& plus_segment() { return plus_segment_; }

  // p ← its tangential part at x⁺ (Euclidean projection onto ker G(x⁺)).
  void tangential_at_plus(Coords& p);
  // Π(M·V⁺) at x⁺: the momentum of the ∂⁺ segment's end, tangential there.
  void plus_segment_momentum(Coords& out);

  // r = (−p̂⁺, 0, +1)·DΦ_{τ⁺} + (p̂⁻, 0, −1)·DΦ_{τ⁻} (or + (p⁻, 0) where τ⁻ = 0) with
  // p̂± = p±·DP(Q±), then ν = (GGᵀ)⁻¹G r_v, ρ_v = r_v − Gᵀν, ρ_q = Π(r_q − Ġᵀν), all at q.
  // Needs evaluate_segments(q, v) first.
  void residual(const Coords& q, const Coords& v, const Coords& p_plus, const Coords& p_minus, long step,
                const DynamicsPrecision& precision = {});
  const Coords& rho_q() const { return rho_q_; }
  const Coords& rho_v() const { return rho_v_; }

  // The step's corrections from the residual (p⁻ = p̄ given):
  //   δp = ρ_q,  δv = M⁻¹(τ⁺ρ_q − ρ_v)/h,  δq = q̄ − ∂⁻(w) − τ⁻δv.
  void step_corrections(const Coords& q, const Coords& qbar, Coords& dq, Coords& dv, Coords& dp) const;
  // Back onto TQ after a correction: q ← P(q) (q ← q̄ where the position is fixed), v ← its
  // M-orthogonal projection onto T_qQ.
  void return_to_tangent_bundle(Coords& q, Coords& v, const Coords& qbar, long step);

  // The standard layer's step Φ_h(w_k) from the state w_k, on TQ: the step's first guess. With
  // α⁻ = 0 that is the accepted ∂⁺ segment's end (q̄, V⁺); otherwise one forward pass, its first
  // stage shared with the accepted segments.
  void standard_step(const State& state, const Coords& qbar, long step, Coords& q, Coords& v);

  // Initialisation ("Initialisation"): p± at a fixed w₀ solve the same residual with p̄ replaced by
  // the unknown p⁻. Their start, M v tangential at x±, and their corrections
  //   δp⁺ = (ρ_v − τ⁻ρ_q)/h,  δp⁻ = δp⁺ − ρ_q.
  void initial_momenta(const Coords& q, const Coords& v, Coords& p_plus, Coords& p_minus);
  void initial_momentum_corrections(Coords& dp_plus, Coords& dp_minus) const;
  // p ← its tangential part at x⁻ (after initial_momenta).
  void tangential_at_minus(Coords& p);

 private:
  Problem& problem_;
  const double h_, alpha_minus_, alpha_plus_;
  ConstrainedDynamics dynamics_;
  ExplicitRungeKutta plus_, minus_;
  Projection projection_;
  // Euclidean projectors onto ker G at q, x⁺ and x⁻; the M-orthogonal one at q.
  TangentProjector euclidean_at_q_, euclidean_at_plus_, euclidean_at_minus_, mass_at_q_;
  Segment plus_segment_, minus_segment_, standard_segment_;
  ProjectedPoint projected_plus_, projected_minus_, projected_q_;
  Coords rho_q_, rho_v_;
  // Scratch of the reverse passes, sized once so steps do not allocate.
  Coords p_hat_, minus_q_bar_, minus_v_bar_, start_direction_, start_hvp_;
  Eigen::VectorXd nu_;
};

}  // namespace vimd
