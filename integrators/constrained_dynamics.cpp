#include "integrators/constrained_dynamics.hpp"

#include "integrators/coords_ops.hpp"

namespace vimd {

ConstrainedDynamics::ConstrainedDynamics(Problem& problem) : problem_(problem) {
  const int n = n_atoms();
  const int d = problem_.constraints.size();
  u_tangent_.setZero(3, n);
  hessian_u_.setZero(3, n);
  z_.setZero(d);
  coefficients_.setZero(d);
}

void ConstrainedDynamics::start_step(const Coords& q) {
  problem_.force_field.start_step(step_pairs_, q);
  in_step_ = true;
}

Evaluation ConstrainedDynamics::evaluation(bool single_precision) {
  Evaluation how;
  how.single_precision = single_precision;
  how.step = in_step_ ? &step_pairs_ : nullptr;
  return how;
}

void ConstrainedDynamics::evaluate(const Coords& q, const Coords& v, DynamicsPoint& point, const Forces* forces_at_q,
                                   bool segment_start, const DynamicsPrecision& precision) {
  const int n = n_atoms();
  const Eigen::VectorXd& inverse_masses = inverse_mass();
  point.q = q;
  point.v = v;
  Evaluation how = evaluation(precision.single_stages && !segment_start);
  how.keep_masks = keep_masks_;
  if (forces_at_q)
    point.forces = *forces_at_q;
  else if (energies_ == Energies::everywhere || (segment_start && problem_.energies_due))
    problem_.force_field.compute(q, point.forces, how);
  else
    problem_.force_field.compute_forces(q, point.forces, how);
  const Coords& f = point.forces.f;
  point.a.resize(3, n);
#pragma omp parallel for schedule(static) if (n >= kParallelMinAtoms)
  for (int i = 0; i < n; ++i) point.a.col(i) = inverse_masses[i] * f.col(i);

  // S λ = −D²g(v,v) − G M⁻¹ f, A = M⁻¹(f + Gᵀλ)
  problem_.constraints.constrain_acceleration(q, v, inverse_masses, point.a, point.lambda, point.s_factor);
  point.lagrangian = kinetic_energy(mass(), v) - point.forces.potential;
}

void ConstrainedDynamics::hessian_vector(const Coords& q, const Coords& u, Coords& out, const Forces* forces_at_q,
                                         const DynamicsPrecision& precision) {
  keep_masks_ = true;
  Evaluation how = evaluation(precision.single_products);
  if (forces_at_q) how.masks = &forces_at_q->masks;
  problem_.force_field.hessian_vector(q, u, out, how);
}

void ConstrainedDynamics::add_vjp(const DynamicsPoint& point, const Coords& a_bar, Coords& q_bar, Coords& v_bar,
                                  Coords* deferred_hvp, const DynamicsPrecision& precision) {
  const int n = n_atoms();
  const Eigen::VectorXd& inverse_masses = inverse_mass();
#pragma omp parallel for schedule(static) if (n >= kParallelMinAtoms)
  for (int i = 0; i < n; ++i) u_tangent_.col(i) = inverse_masses[i] * a_bar.col(i);

  const Constraints& c = problem_.constraints;
  if (!c.empty()) {
    // ũ = u − M⁻¹Gᵀz is the M-orthogonal projection of u = M⁻¹ā onto ker G.
    c.project_onto_kernel(point.s_factor, inverse_masses, u_tangent_, z_);
    coefficients_ = -z_;
  }
  if (deferred_hvp) {
#pragma omp parallel for schedule(static) if (n >= kParallelMinAtoms)
    for (int i = 0; i < n; ++i) deferred_hvp->col(i) += u_tangent_.col(i);
  } else {
    hessian_vector(point.q, u_tangent_, hessian_u_, &point.forces, precision);
#pragma omp parallel for schedule(static) if (n >= kParallelMinAtoms)
    for (int i = 0; i < n; ++i) q_bar.col(i) -= hessian_u_.col(i);
  }
  if (!c.empty()) {
    c.add_H(point.lambda, u_tangent_, q_bar);
    c.add_H(coefficients_, point.a, q_bar);
    coefficients_ *= 2;
    c.add_H(coefficients_, point.v, v_bar);
  }
}

}  // namespace vimd
