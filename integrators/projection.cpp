#include "integrators/projection.hpp"

#include <cmath>
#include <limits>

#include "engine/errors.hpp"
#include "integrators/coords_ops.hpp"

namespace vimd {

TangentProjector::TangentProjector(const Constraints& constraints, Eigen::VectorXd inverse_weights)
    : constraints_(constraints), inverse_weights_(std::move(inverse_weights)) {}

void TangentProjector::set_point(const Coords& q) {
  if (!constraints_.empty()) constraints_.factorize(q, q, inverse_weights_, factor_);
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
    throw SettingError("integrator", "projection",
                       "projection must be \"euclidean\" or \"mass\", not \"" + kind + "\"");
}

Projection::Projection(const Constraints& constraints, const Eigen::VectorXd& inverse_mass, const std::string& kind)
    : closest_point_(constraints) {
  check_projection_kind(kind);
  inverse_weights_ = kind == "mass" ? inverse_mass : Eigen::VectorXd::Ones(inverse_mass.size());
  length_scale_ = std::numeric_limits<double>::infinity();
  for (const auto& c : constraints.list()) length_scale_ = std::min(length_scale_, c.length);
}

void Projection::project(const Coords& y, ProjectedPoint& out, long step) {
  constexpr int kMaxIterations = 50;
  out.iterations = 0;
  // Converged once the update is at the level where rounding in the positions dominates.
  const double size = max_abs(y);
  if (!std::isfinite(size))
    throw ConvergenceError("projection onto the constraints", step, 0, size, "non-finite positions");
  const double tolerance = 1e-13 * length_scale_ + 8 * std::numeric_limits<double>::epsilon() * size;
  const ClosestPoint::Outcome solve =
      closest_point_.project(y, inverse_weights_, tolerance, kMaxIterations, out.x, out.theta, out.s_factor);
  if (!solve.converged)
    throw ConvergenceError("projection onto the constraints", step, solve.iterations, solve.residual,
                           "the step moved the positions too far from the constraint surface");
  out.iterations = solve.iterations;
}

void Projection::pull_back(const ProjectedPoint& point, const Coords& p, Coords& p_hat, long step) {
  constexpr int kMaxSweeps = 20;
  const double size = max_abs(p);
  if (!std::isfinite(size))
    throw ConvergenceError("covector pull-back through the projection", step, 0, size, "non-finite momenta");
  const ClosestPoint::Outcome solve = closest_point_.pull_back(point.x, point.theta, point.s_factor, inverse_weights_,
                                                               p, 1e-14 * size, kMaxSweeps, p_hat);
  if (!solve.converged)
    throw ConvergenceError("covector pull-back through the projection", step, solve.iterations, solve.residual,
                           "the projection multipliers are too large");
}

}  // namespace vimd
