#pragma once
// The variational integrator converted from one-step methods (Patrick, Cuell, Spiteri, Zhang;
// spec §4–6). Segments ∂±(w) = P(Q_{τ±}(w)) with τ± = h α±, discrete Lagrangian
// L_h(w) = S_{τ⁺}(w) − S_{τ⁻}(w), momenta p± from DL_h = −p⁻·D∂⁻ + p⁺·D∂⁺ on T_w TQ.
// Carried state: w_k = (q_k, v_k) ∈ TQ (the State) and the cotangent point (q̄, p̄) = (∂⁺(w_k), p⁺(w_k)).
// A step solves ∂⁻(w) = q̄, p⁻(w) = p̄ by the fixed-point iteration with approximate Jacobian
// (q_τ ≈ q + τv, S_τ ≈ τL); each iteration is one forward and one reverse pass per segment.
#include <memory>
#include <string>
#include <vector>

#include "engine/config.hpp"
#include "engine/integrator.hpp"
#include "integrators/tableau.hpp"

namespace vimd {

struct VariationalSettings {
  ButcherTableau plus, minus;  // methods for the ∂⁺ and ∂⁻ segments
  double dt = 0.002;           // ps
  double alpha_minus = 0, alpha_plus = 1;
  std::string projection = "euclidean";  // W = I, or "mass" (W = M)
  // Stop when max(‖δv‖∞, ‖δq‖∞/h) ≤ tolerance (nm/ps). The last evaluated point is
  // accepted as it is, so no evaluation is spent only to confirm convergence.
  double tolerance = 1e-8;
  int max_iterations = 50;
  int anderson_depth = 0;  // 0: plain fixed-point iteration; m > 0: Anderson mixing over m differences
  // Predictor: the standard layer's step Φ_h(w_k) for (q, v) and Π(M·V⁺) for p⁺, each corrected
  // by its difference between solution and prediction, extrapolated from the last
  // `predictor_history` steps by a polynomial (0: uncorrected, 1: last step's, 2: linear, 3: quadratic;
  // kAutomaticHistory: what needed the fewest iterations on water900, rk4 at 2 fs: 3 with α⁻ = 0
  // (2.02 residual evaluations per step against 2.28 with 1), 1 otherwise (4.03 against 5.00 with 3
  // at [−½, ½]).
  static constexpr int kAutomaticHistory = -1;
  int predictor_history = kAutomaticHistory;
  int predictor_history_used() const;
  // Also stop when the update about to be applied is predicted to land within the tolerance
  // (contraction factor × ‖δ‖, the factor being the largest seen in this and the last step); the
  // step then ends with the ∂⁺ segment at the updated point (a forward pass, or with
  // linear_final_segment its first-order advance) instead of another residual.
  bool predicted_stop = true;
  // With α⁻ = 0, a predicted stop advances the ∂⁺ segment to the updated point to first order
  // instead of by a forward pass (see advance_plus_segment_linearly).
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
  struct Work;
  Work& work(Problem& problem, const char* caller);
  void forward_segments(Work& w, const Coords& q, const Coords& v, long step, const Forces* forces_at_q = nullptr,
                        bool plus_only = false);
  void residual(Work& w, const Coords& q, const Coords& v, const Coords& p_plus, const Coords& p_minus, long step);
  void predict(Work& w, const State& state, long step);
  // Applies (δq, δv, δp) scaled by `relaxation` (Anderson-mixed unless `plain`) and returns to TQ.
  void update(Work& w, int iteration, long step, double relaxation, bool plain = false);
  void advance_plus_segment_linearly(Work& w, long step);
  void write_state(Work& w, State& state) const;
  // Pushes the accepted point's offsets (solution minus prediction) into the predictor's history;
  // with_state: the position and velocity offsets too (not at init, which has no prediction).
  void record_offsets(Work& w, bool with_state) const;
  void extrapolate_offsets(Work& w) const;

  VariationalSettings settings_;
  std::unique_ptr<Work> work_;
};

}  // namespace vimd
