#pragma once
// Control of a fixed-point iteration x ← x + relaxation·δ(x) from the size of its residual alone
// (docs/variational-integrator.md, "Solving the step"): when it has converged, when to damp it, when
// it has settled on a jump of the residual, and when the next update may end it unconfirmed.
// It knows nothing of what x is.
namespace vimd {

class FixedPointControl {
 public:
  enum class Verdict {
    update,               // apply the update, relaxed by relaxation(), and evaluate again
    converged,            // the residual is within the tolerance: keep the iterate
    settled_at_jump,      // keep the iterate: the residual jumps (no root) and the damped iteration settled on the jump
    converged_by_update,  // apply the full update and stop: it is predicted to land within the tolerance
    not_finite,           // the residual is not finite
    exhausted,            // max_iterations reached without convergence
  };

  // `predicted_stop`: whether converged_by_update may end an iteration.
  FixedPointControl(int max_iterations, bool predicted_stop);

  // A new solve to `tolerance` (the same norm as the residuals judged).
  void begin(double tolerance);
  // Judges the next iterate's residual. `may_end` false: this iterate cannot end the solve (its
  // residual is only good enough to steer the iteration).
  Verdict judge(double residual, bool may_end = true);

  int iterations() const { return iterations_; }
  double relaxation() const { return relaxation_; }
  double tolerance() const { return tolerance_; }
  // After converged_by_update: the residual expected at the updated point (contraction × residual).
  double predicted_residual() const { return predicted_residual_; }
  // The contraction factor estimate carried from one solve to the next (1: unknown); checkpoints
  // save and restore it.
  double contraction() const { return carried_contraction_; }
  void set_contraction(double contraction) { carried_contraction_ = contraction; }

 private:
  // At the end of a solve: its largest contraction factor becomes the next solve's estimate.
  void finish();

  const int max_iterations_;
  const bool predicted_stop_;
  double tolerance_ = 0;
  int iterations_ = 0;
  double previous_ = 0, before_previous_ = 0;  // the last two residuals
  double relaxation_ = 1;
  // Largest contraction factor residual_k/residual_{k−1} of this solve, and of the last one.
  double contraction_ = 0, carried_contraction_ = 1;
  double predicted_residual_ = 0;
};

}  // namespace vimd
