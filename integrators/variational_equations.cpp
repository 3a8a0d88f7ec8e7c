#include "integrators/variational_equations.hpp"

#include "integrators/coords_ops.hpp"

namespace vimd {

VariationalEquations::VariationalEquations(Problem& problem, const ButcherTableau& plus, const ButcherTableau& minus,
                                           double h, double alpha_minus, double alpha_plus,
                                           const std::string& projection)
    : problem_(problem),
      h_(h),
      alpha_minus_(alpha_minus),
      alpha_plus_(alpha_plus),
      dynamics_(problem),
      plus_(plus),
      minus_(minus),
      projection_(problem.constraints, problem.inverse_mass, projection),
      euclidean_at_q_(problem.constraints, Eigen::VectorXd::Ones(problem.inverse_mass.size())),
      euclidean_at_plus_(problem.constraints, Eigen::VectorXd::Ones(problem.inverse_mass.size())),
      euclidean_at_minus_(problem.constraints, Eigen::VectorXd::Ones(problem.inverse_mass.size())),
      mass_at_q_(problem.constraints, problem.inverse_mass) {
  // The solve needs forces alone; the state (a segment start) gets its energies when they are due.
  dynamics_.set_energies(ConstrainedDynamics::Energies::at_due_starts);
  const int n = static_cast<int>(problem.inverse_mass.size());
  for (Coords* c : {&rho_q_, &rho_v_, &p_hat_, &minus_q_bar_, &minus_v_bar_, &start_direction_, &start_hvp_})
    c->setZero(3, n);
}

void VariationalEquations::evaluate_segments(const Coords& q, const Coords& v, long step, const Forces* forces_at_q,
                                             bool plus_only, const DynamicsPrecision& precision) {
  plus_.forward(dynamics_, q, v, h_ * alpha_plus_, plus_segment_, forces_at_q, precision);
  projection_.project(plus_segment_.q, projected_plus_, step);
  if (alpha_minus_ != 0 && !plus_only) {
    // Both segments start at w: the first stage's forces are shared.
    minus_.forward(dynamics_, q, v, h_ * alpha_minus_, minus_segment_, &plus_segment_.stages[0].forces, precision);
    projection_.project(minus_segment_.q, projected_minus_, step);
  }
  euclidean_at_plus_.set_point(projected_plus_.x);
}

void VariationalEquations::advance_plus_segment_linearly(const Coords& v, const Coords& v_before, long step) {
  const double tau_plus = h_ * alpha_plus_;
  parallel_assign(plus_segment_.q, plus_segment_.q + tau_plus * (v - v_before));
  parallel_assign(plus_segment_.v, plus_segment_.v + (v - v_before));
  projection_.project(plus_segment_.q, projected_plus_, step);
  euclidean_at_plus_.set_point(projected_plus_.x);
}

void VariationalEquations::tangential_at_plus(Coords& p) { euclidean_at_plus_.apply(p); }
void VariationalEquations::tangential_at_minus(Coords& p) { euclidean_at_minus_.apply(p); }

void VariationalEquations::plus_segment_momentum(Coords& out) {
  parallel_assign(out, scaled_per_atom(problem_.system.mass, plus_segment_.v));
  euclidean_at_plus_.apply(out);
}

void VariationalEquations::residual(const Coords& q, const Coords& v, const Coords& p_plus, const Coords& p_minus,
                                    long step, const DynamicsPrecision& precision) {
  projection_.pull_back(projected_plus_, p_plus, p_hat_, step);
  parallel_assign(p_hat_, -p_hat_);
  if (alpha_minus_ != 0) {
    // Both segments start at q: one Hessian–vector product there serves both reverse passes.
    start_direction_.setZero();
    plus_.vjp(dynamics_, plus_segment_, p_hat_, nullptr, 1.0, rho_q_, rho_v_, &start_direction_, precision);
    projection_.pull_back(projected_minus_, p_minus, p_hat_, step);
    minus_.vjp(dynamics_, minus_segment_, p_hat_, nullptr, -1.0, minus_q_bar_, minus_v_bar_, &start_direction_,
               precision);
    dynamics_.hessian_vector(q, start_direction_, start_hvp_, &plus_segment_.stages[0].forces, precision);
    parallel_assign(rho_q_, rho_q_ + (minus_q_bar_ - start_hvp_));
    parallel_assign(rho_v_, rho_v_ + minus_v_bar_);
  } else {
    plus_.vjp(dynamics_, plus_segment_, p_hat_, nullptr, 1.0, rho_q_, rho_v_, nullptr, precision);
    parallel_assign(rho_q_, rho_q_ + p_minus);
  }
  const Constraints& constraints = problem_.constraints;
  if (constraints.empty()) return;
  euclidean_at_q_.set_point(q);
  euclidean_at_q_.apply(rho_v_, &nu_);
  nu_ = -nu_;
  constraints.add_H(nu_, v, rho_q_);
  euclidean_at_q_.apply(rho_q_);
}

void VariationalEquations::step_corrections(const Coords& q, const Coords& qbar, Coords& dq, Coords& dv,
                                            Coords& dp) const {
  const double tau_plus = h_ * alpha_plus_, tau_minus = h_ * alpha_minus_;
  const Coords& x_minus = this->x_minus(q);
  parallel_assign(dp, rho_q_);
  parallel_assign(dv, scaled_per_atom(problem_.inverse_mass, tau_plus * rho_q_ - rho_v_) / h_);
  parallel_assign(dq, qbar - x_minus - tau_minus * dv);
}

void VariationalEquations::return_to_tangent_bundle(Coords& q, Coords& v, const Coords& qbar, long step) {
  if (position_fixed()) {
    // The M-orthogonal projector is already at q̄ (standard_step put it there).
    parallel_assign(q, qbar);
  } else {
    projection_.project(q, projected_q_, step);
    parallel_assign(q, projected_q_.x);
    mass_at_q_.set_point(q);
  }
  mass_at_q_.apply(v);
}

void VariationalEquations::standard_step(const State& state, const Coords& qbar, long step, Coords& q, Coords& v) {
  if (position_fixed()) {
    // ∂⁻(w) = q, so q = q̄ exactly; the accepted ∂⁺ segment is the standard step Φ_h(w_k).
    parallel_assign(q, qbar);
    parallel_assign(v, plus_segment_.v);
  } else {
    plus_.forward(dynamics_, state.q, state.v, h_, standard_segment_, &plus_segment_.stages[0].forces);
    projection_.project(standard_segment_.q, projected_q_, step);
    parallel_assign(q, projected_q_.x);
    parallel_assign(v, standard_segment_.v);
  }
  mass_at_q_.set_point(q);
  mass_at_q_.apply(v);
}

void VariationalEquations::initial_momenta(const Coords& q, const Coords& v, Coords& p_plus, Coords& p_minus) {
  parallel_assign(p_plus, scaled_per_atom(problem_.system.mass, v));
  parallel_assign(p_minus, p_plus);
  euclidean_at_plus_.apply(p_plus);
  euclidean_at_minus_.set_point(x_minus(q));
  euclidean_at_minus_.apply(p_minus);
}

void VariationalEquations::initial_momentum_corrections(Coords& dp_plus, Coords& dp_minus) const {
  const double tau_minus = h_ * alpha_minus_;
  parallel_assign(dp_plus, (rho_v_ - tau_minus * rho_q_) / h_);
  parallel_assign(dp_minus, dp_plus - rho_q_);
}

}  // namespace vimd
