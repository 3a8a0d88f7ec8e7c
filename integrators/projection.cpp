#include "integrators/projection.hpp"

#include <cmath>
#include <limits>

#include "engine/errors.hpp"
#include "integrators/coords_ops.hpp"

namespace vimd {

TangentProjector::TangentProjector(const Constraints& constraints, Eigen::VectorXd inverse_weights)
    : constraints_(constraints), inverse_weights_(std::move(inverse_weights)) {}

void TangentProjector::set_point(const Coords& q) {
  q_ = q;
  if (!constraints_.empty()) constraints_.factorize(q_, q_, inverse_weights_, factor_);
}

void TangentProjector::apply(Coords& u, Eigen::VectorXd* mu) {
  if (constraints_.empty()) {
    if (mu) mu->resize(0);
    return;
  }
  constraints_.project_onto_kernel(factor_, inverse_weights_, u, mu ? *mu : mu_);
}

void check_projection_kind(const std::string& kind) {
  if (kind != "euclidean" && kind != "mass")
    throw InputError("[integrator]", 0, "projection must be \"euclidean\" or \"mass\", not \"" + kind + "\"");
}

Projection::Projection(const Constraints& constraints, const Eigen::VectorXd& inverse_mass, const std::string& kind)
    : constraints_(constraints) {
  check_projection_kind(kind);
  inverse_weights_ = kind == "mass" ? inverse_mass : Eigen::VectorXd::Ones(inverse_mass.size());
  length_scale_ = std::numeric_limits<double>::infinity();
  for (const auto& c : constraints.list()) length_scale_ = std::min(length_scale_, c.length);
}

void Projection::project(const Coords& y, ProjectedPoint& out, long step) {
  constexpr int kMaxIterations = 50;
  out.x.resize(3, y.cols());
  parallel_assign(out.x, y);
  out.iterations = 0;
  const int d = constraints_.size();
  out.theta.setZero(d);
  if (d == 0) return;
  const int n = static_cast<int>(y.cols());
  const Eigen::VectorXd& w = inverse_weights_;
  // Converged once the update is at the level where rounding in the positions dominates.
  const double size = max_abs(y);
  if (!std::isfinite(size))
    throw ConvergenceError("projection onto the constraints", step, 0, size, "non-finite positions");
  const double tolerance = 1e-13 * length_scale_ + 8 * std::numeric_limits<double>::epsilon() * size;
  r1_.resize(3, n);
  dx_.resize(3, n);
  double change = std::numeric_limits<double>::infinity();
  while (change > tolerance) {
    if (out.iterations == kMaxIterations || (out.iterations > 0 && !std::isfinite(change)))
      throw ConvergenceError("projection onto the constraints", step, out.iterations, change,
                             "the step moved the positions too far from the constraint surface");
    ++out.iterations;
    // R1 = x + W⁻¹Gᵀθ − y,  R2 = g(x);  dθ = S⁻¹(R2 − G R1),  dx = −R1 − W⁻¹Gᵀdθ.
    parallel_assign(r1_, out.x - y);
    constraints_.add_GT(out.x, out.theta, r1_, w);
    constraints_.residuals(out.x, g_);
    constraints_.factorize(out.x, out.x, w, out.s_factor);
    constraints_.apply_G(out.x, r1_, gr_);
    dtheta_ = g_ - gr_;
    out.s_factor.solve(dtheta_);
    parallel_assign(dx_, -r1_);
    gr_ = -dtheta_;
    constraints_.add_GT(out.x, gr_, dx_, w);
    parallel_assign(out.x, out.x + dx_);
    out.theta += dtheta_;
    change = max_abs(dx_);
  }
}

void Projection::pull_back(const ProjectedPoint& point, const Coords& p, Coords& p_hat, long step) {
  constexpr int kMaxSweeps = 20;
  p_hat.resize(3, p.cols());
  parallel_assign(p_hat, p);
  const int d = constraints_.size();
  if (d == 0) return;
  const int n = static_cast<int>(p.cols());
  const Eigen::VectorXd& w = inverse_weights_;
  const Coords& x = point.x;
  const double size = max_abs(p);
  if (!std::isfinite(size))
    throw ConvergenceError("covector pull-back through the projection", step, 0, size, "non-finite momenta");
  const double tolerance = 1e-14 * size;
  b_.setZero(d);
  r1_.resize(3, n);
  scaled_.resize(3, n);
  for (int sweep = 0; sweep < kMaxSweeps; ++sweep) {
    // r1 = p − (I + Σθ_a H_a W⁻¹) p̂ − Gᵀb,  r2 = −G W⁻¹ p̂;
    // correction from [[I, Gᵀ], [G W⁻¹, 0]]: db = S⁻¹(G W⁻¹ r1 − r2), dp = r1 − Gᵀ db.
    for_each_atom(n, [&](int i) { scaled_.col(i) = w[i] * p_hat.col(i); });
    parallel_assign(r1_, p - p_hat);
    gr_ = -point.theta;
    constraints_.add_H(gr_, scaled_, r1_);
    gr_ = -b_;
    constraints_.add_GT(x, gr_, r1_);
    constraints_.apply_G(x, scaled_, g_);  // −r2
    for_each_atom(n, [&](int i) { scaled_.col(i) = w[i] * r1_.col(i); });
    constraints_.apply_G(x, scaled_, db_);
    db_ += g_;
    point.s_factor.solve(db_);
    b_ += db_;
    gr_ = -db_;
    constraints_.add_GT(x, gr_, r1_);
    parallel_assign(p_hat, p_hat + r1_);
    if (max_abs(r1_) <= tolerance) return;
  }
  throw ConvergenceError("covector pull-back through the projection", step, kMaxSweeps, max_abs(r1_),
                         "the projection multipliers are too large");
}

}  // namespace vimd
