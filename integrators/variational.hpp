#pragma once
// The variational integrator converted from one-step methods (Patrick, Cuell, Spiteri, Zhang; see
// docs/variational-integrator.md). Carried state: w_k = (q_k, v_k) ∈ TQ (the State) and the
// cotangent point (q̄, p̄) = (∂⁺(w_k), p⁺(w_k)). A step solves ∂⁻(w) = q̄, p⁻(w) = p̄ for w
// (VariationalEquations) by a fixed-point iteration (FixedPointControl, optionally AndersonMixer)
// from a predicted start (StepPredictor); this class wires them together and decides which
// evaluations may be single precision.
#include <memory>
#include <string>
#include <vector>

#include "integrators/settings.hpp"
#include "engine/integrator.hpp"
#include "integrators/tableau.hpp"

namespace vimd {

struct DynamicsPrecision;  // integrators/constrained_dynamics.hpp

struct VariationalSettings {
  ButcherTableau plus, minus;  // methods for the ∂⁺ and ∂⁻ segments
  double dt = 0.002;           // ps
  double alpha_minus = 0, alpha_plus = 1;
  std::string projection = "euclidean";  // W = I, or "mass" (W = M)
  // Stop when max(‖δv‖∞, ‖δq‖∞/h) ≤ tolerance (nm/ps). The last evaluated point is
  // accepted as it is, so no evaluation is spent only to confirm convergence.
  double tolerance = 1e-8;
  // Instead, each step's tolerance from the last step's offset (StepPredictor::newest_offset_size:
  // the distance between the solution and the method's own explicit step, the scale of the local
  // truncation error): kToleranceOfOffset times it, so the solve's error stays a small fraction of
  // the truncation error at every method, step and system; `tolerance` until an offset is known.
  bool tolerance_from_offset = false;
  static constexpr double kToleranceOfOffset = 1e-2;
  int max_iterations = 50;
  int anderson_depth = 0;  // 0: plain fixed-point iteration; m > 0: Anderson mixing over m differences
  // Predictor (StepPredictor): the standard layer's step Φ_h(w_k) for (q, v) and Π(M·V⁺) for p⁺,
  // each corrected by its difference between solution and prediction, extrapolated from the last
  // `predictor_history` steps by a polynomial (0: uncorrected, 1: last step's, 2: linear, 3: quadratic;
  // kAutomaticHistory: the degree that needed the fewest residual evaluations per step on SPC/E
  // water, rk4 at 2 fs (validation/bench_vi): 3 with α⁻ = 0, 1 otherwise).
  static constexpr int kAutomaticHistory = -1;
  int predictor_history = kAutomaticHistory;
  int predictor_history_used() const;
  // Also stop when the update about to be applied is predicted to land within the tolerance
  // (contraction factor × ‖δ‖, the factor being the largest seen in this and the last step); the
  // step then ends with the ∂⁺ segment at the updated point (a forward pass, or with
  // linear_final_segment its first-order advance) instead of another residual.
  bool predicted_stop = true;
  // With α⁻ = 0, a predicted stop advances the ∂⁺ segment to the updated point to first order
  // instead of by a forward pass (VariationalEquations::advance_plus_segment_linearly).
  bool linear_final_segment = true;
  // A mixed-precision solve, where the force field has single-precision pair kernels:
  // - the first iteration evaluates its stages (not a segment's start) and its Hessian–vector
  //   products in single precision: it starts from the prediction, whose error is far above their
  //   rounding, and the iterations after it, in double, correct both; so it never ends a step (it
  //   rarely could anyway);
  // - with a tolerance of at least kSingleProductsMinTolerance, every iteration's Hessian–vector
  //   products are single precision: they enter the residual only through the adjoint's O(τ²)
  //   terms, where their rounding moves it by ~2e-11 nm/ps (SPC/E water at 2 fs: below that the
  //   iteration stalls), far below such a tolerance.
  bool mixed_precision_solve = true;
  static constexpr double kSingleProductsMinTolerance = 1e-8;  // nm/ps

  // From [integrator]; InputError for a bad bias or projection. `file` names the config in errors.
  static VariationalSettings from_config(const IntegratorConfig& config, const std::string& file = "[integrator]");
};

// The default solver tolerance (nm/ps) for a bias, calibrated on SPC/E water at 2 fs: the loosest
// value whose energy fluctuation and drift match a tighter one (validation/bench_vi).
double default_solver_tolerance(double alpha_minus);

class VariationalIntegrator : public Integrator {
 public:
  explicit VariationalIntegrator(VariationalSettings settings);
  // From [integrator] (type = "vi"); InputError on bad settings.
  explicit VariationalIntegrator(const IntegratorConfig& config);
  ~VariationalIntegrator() override;

  std::string name() const override { return "vi"; }
  void init(Problem& problem, State& state) override;
  StepReport step(Problem& problem, State& state) override;
  // iterations, final residual (nm/ps), 1 if the step settled on a jump of the residual (a pair
  // crossing the cut-off; residual then above the tolerance but within 100×), discrete Noether
  // linear momentum Σ p̄ (amu nm/ps).
  std::vector<std::string> diagnostic_names() const override;
  // (q̄, p̄), the predictor's offsets and contraction estimate, and the accepted ∂⁺ segment's end
  // velocity (the next prediction starts from it).
  Carried carried_state() const override;
  void restore(Problem& problem, const State& state, const Carried& carried) override;

  const VariationalSettings& settings() const { return settings_; }
  const Coords& qbar() const;
  const Coords& pbar() const;
  // Replaces (q̄, p̄), e.g. to study the map (q̄, p̄) ↦ (q̄′, p̄′); the predictor still starts from state.
  void set_cotangent(const Coords& qbar, const Coords& pbar);

 private:
  struct Run;
  Run& bound_run(Problem& problem, const char* caller);
  // Sets (q, v) to the step's first guess.
  void predict(Run& run, const State& state, long step);
  struct SolveOutcome;
  // The solve's tolerance for this step: the set one (or the predictor's offset's share of it),
  // no tighter than the state's round-off.
  double step_tolerance(const Run& run, const State& state) const;
  // Iterates from the prediction until the controller stops; `mixed`: a mixed-precision solve.
  SolveOutcome solve(Run& run, long step, bool mixed);
  // Evaluates the equations at the iterate (the segments, the residual, the corrections).
  void evaluate(Run& run, int iteration, long step, const DynamicsPrecision& precision);
  // A predicted stop: the full update, and the ∂⁺ segment at the updated point.
  void finish_by_update(Run& run, long step);
  // Takes the solved w as the step: (q̄, p̄), the predictor's record and the State.
  void accept(Run& run, const SolveOutcome& outcome, State& state) const;
  StepReport report(const Run& run, const SolveOutcome& outcome) const;
  // Applies the corrections scaled by `relaxation`, Anderson-mixed if `mix` (and the mixer is on
  // and the update undamped), and returns to TQ.
  void update(Run& run, long step, double relaxation, bool mix);
  void write_state(const Run& run, State& state) const;

  VariationalSettings settings_;
  std::unique_ptr<Run> run_;
};

}  // namespace vimd
