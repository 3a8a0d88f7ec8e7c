#include "integrators/fixed_point.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace vimd {

namespace {

// Damp when the residual fell by less than this over two iterations (the plain iteration's
// convergence is not monotone, and a cycle across a jump repeats every other iteration).
constexpr double kNoProgress = 0.95;
constexpr double kMinRelaxation = 1.0 / 1024;
// A damped iteration has settled on a jump when its steps are within the tolerance while the
// residual, which cannot vanish there, stays within this factor of it.
constexpr double kJumpFactor = 100;

}  // namespace

FixedPointControl::FixedPointControl(int max_iterations, bool predicted_stop)
    : max_iterations_(max_iterations), predicted_stop_(predicted_stop) {}

void FixedPointControl::begin(double tolerance) {
  tolerance_ = tolerance;
  iterations_ = 0;
  previous_ = before_previous_ = std::numeric_limits<double>::infinity();
  relaxation_ = 1;
  contraction_ = 0;
  predicted_residual_ = 0;
}

void FixedPointControl::finish() {
  if (iterations_ > 1) carried_contraction_ = std::min(contraction_, 1.0);
}

FixedPointControl::Verdict FixedPointControl::judge(double residual, bool may_end) {
  ++iterations_;
  if (!std::isfinite(residual)) return Verdict::not_finite;
  if (residual <= tolerance_ && may_end) {
    finish();
    return Verdict::converged;
  }
  if (iterations_ > 1) contraction_ = std::max(contraction_, residual / previous_);
  // Relaxation halves while the residual stops decreasing, and recovers on good progress. The
  // residual jumps where the map is discontinuous; then no root exists, the plain iteration
  // cycles across the jump, and the damped one settles on it.
  if (residual > kNoProgress * before_previous_)
    relaxation_ = std::max(0.5 * relaxation_, kMinRelaxation);
  else if (residual < 0.5 * previous_)
    relaxation_ = std::min(2 * relaxation_, 1.0);
  if (may_end && relaxation_ < 1 && relaxation_ * residual <= tolerance_ && residual <= kJumpFactor * tolerance_) {
    finish();
    return Verdict::settled_at_jump;
  }
  if (iterations_ >= max_iterations_) return Verdict::exhausted;
  before_previous_ = previous_;
  previous_ = residual;
  // The update lands within contraction × residual of the solution; the estimate is the larger
  // of this solve's factor and the last one's.
  const double contraction = std::max(contraction_, carried_contraction_);
  if (predicted_stop_ && may_end && iterations_ > 1 && relaxation_ == 1 && contraction * residual <= tolerance_) {
    predicted_residual_ = residual * contraction;
    finish();
    return Verdict::converged_by_update;
  }
  return Verdict::update;
}

}  // namespace vimd
