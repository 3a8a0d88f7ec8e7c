#include "integrators/variational.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>

#include "engine/errors.hpp"
#include "integrators/anderson.hpp"
#include "integrators/coords_ops.hpp"
#include "integrators/fixed_point.hpp"
#include "integrators/projection.hpp"
#include "integrators/step_predictor.hpp"
#include "integrators/thermostat.hpp"
#include "integrators/variational_equations.hpp"
#include "integrators/verlet.hpp"

namespace vimd {

namespace {

// The Anderson mixer's blocks, one per atom: (q/h, v, M⁻¹p⁺), in nm/ps each.
constexpr int kAndersonEntriesPerAtom = 9;

std::string format_tolerance(double x) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3g", x);
  return buf;
}

}  // namespace

VariationalSettings VariationalSettings::from_config(const IntegratorConfig& config, const std::string& file) {
  check_step_config(config);
  refuse_thermostat(config,
                    "the variational integrators stay NVE (a thermostat would break the symplectic, "
                    "momentum-conserving discrete dynamics they exist for); equilibrate with type = \"rattle\" and "
                    "thermostat = \"v-rescale\", then continue from its confout.gro with type = \"vi\"");
  if (config.solver_tolerance && !(*config.solver_tolerance > 0))
    throw SettingError("integrator", "solver_tolerance",
                       "solver_tolerance must be positive (nm/ps), got " + format_tolerance(*config.solver_tolerance));
  VariationalSettings s;
  s.plus = resolve_tableau(config.method, config, file);
  s.minus = config.method_minus ? resolve_tableau(*config.method_minus, config, file) : s.plus;
  s.dt = config.dt;
  s.alpha_minus = config.bias[0];
  s.alpha_plus = config.bias[1];
  if (!(s.alpha_minus >= -1 && s.alpha_minus <= 0 && s.alpha_plus >= 0 && s.alpha_plus <= 1) ||
      std::abs(s.alpha_plus - s.alpha_minus - 1) > 1e-12)
    throw SettingError("integrator", "bias",
                       "bias = [" + std::to_string(s.alpha_minus) + ", " + std::to_string(s.alpha_plus) +
                           "] must satisfy -1 <= alpha_minus <= 0 <= alpha_plus <= 1 and alpha_plus - alpha_minus = 1");
  check_projection_kind(config.projection);
  s.projection = config.projection;
  s.tolerance = config.solver_tolerance ? *config.solver_tolerance : default_solver_tolerance(s.alpha_minus);
  s.tolerance_from_offset = config.solver_tolerance_auto;
  s.max_iterations = config.max_iterations;
  if (config.acceleration == "anderson")
    s.anderson_depth = 4;
  else if (config.acceleration != "none")
    throw SettingError("integrator", "acceleration",
                       "acceleration must be \"none\" or \"anderson\", not \"" + config.acceleration + "\"");
  if (config.solver_precision != "mixed" && config.solver_precision != "double")
    throw SettingError("integrator", "solver_precision",
                       "solver_precision must be \"mixed\" or \"double\", not \"" + config.solver_precision + "\"");
  s.mixed_precision_solve = config.solver_precision == "mixed";
  return s;
}

int VariationalSettings::predictor_history_used() const {
  if (predictor_history != kAutomaticHistory) return predictor_history;
  return alpha_minus == 0 ? StepPredictor::kMaxHistory : 1;
}

double default_solver_tolerance(double alpha_minus) {
  // Calibrated by validation/bench_vi (SPC/E water, 2 fs, rk4): with α⁻ < 0 the two segments'
  // errors add, so it needs a tighter tolerance than α⁻ = 0 for the same energy drift. Lower-order
  // methods have larger truncation errors, so the same values are safe for them.
  return alpha_minus == 0 ? 1e-6 : 1e-7;
}

// Everything a run needs, built at init() for its Problem; sized once so steps do not allocate.
struct VariationalIntegrator::Run {
  Problem* problem;
  VariationalEquations equations;
  StepPredictor predictor;
  FixedPointControl control;
  std::optional<AndersonMixer<kAndersonEntriesPerAtom>> mixer;  // with Anderson mixing
  Coords q, v, p_plus;          // the unknowns: w = (q, v) and p⁺
  Coords qbar, pbar;            // the cotangent state (q̄, p̄)
  Coords dq, dv, dp;            // the fixed-point map's corrections at the iterate
  Coords q_trial, v_trial;      // the iterate after an update, before it is accepted
  Coords v_before_update;       // for the ∂⁺ segment's linear advance after a final update
  Coords plus_segment_momentum; // Π(M·V⁺), for the predictor

  Run(Problem& p, const VariationalSettings& s)
      : problem(&p),
        equations(p, s.plus, s.minus, s.dt, s.alpha_minus, s.alpha_plus, s.projection),
        predictor(static_cast<int>(p.inverse_mass.size()), s.predictor_history_used()),
        control(s.max_iterations, s.predicted_stop) {
    const int n = static_cast<int>(p.inverse_mass.size());
    if (s.anderson_depth > 0) mixer.emplace(s.anderson_depth, n);
    for (Coords* c : {&q, &v, &p_plus, &qbar, &pbar, &dq, &dv, &dp, &q_trial, &v_trial, &v_before_update,
                      &plus_segment_momentum})
      c->setZero(3, n);
  }
};

VariationalIntegrator::VariationalIntegrator(VariationalSettings settings) : settings_(std::move(settings)) {
  if (settings_.anderson_depth < 0 || settings_.anderson_depth > kMaxAndersonDepth)
    throw std::invalid_argument("Anderson depth must be between 0 and " + std::to_string(kMaxAndersonDepth));
  if (settings_.predictor_history < VariationalSettings::kAutomaticHistory ||
      settings_.predictor_history > StepPredictor::kMaxHistory)
    throw std::invalid_argument("predictor history must be between 0 and " +
                                std::to_string(StepPredictor::kMaxHistory) + ", or automatic");
}
VariationalIntegrator::VariationalIntegrator(const IntegratorConfig& config)
    : VariationalIntegrator(VariationalSettings::from_config(config)) {}
VariationalIntegrator::~VariationalIntegrator() = default;

std::vector<std::string> VariationalIntegrator::diagnostic_names() const {
  std::vector<std::string> names = {"vi_iterations", "vi_residual", "vi_jump", "noether_px", "noether_py", "noether_pz"};
  if (settings_.tolerance_from_offset) names.push_back("vi_tolerance");
  return names;
}

const Coords& VariationalIntegrator::qbar() const { return run_->qbar; }
const Coords& VariationalIntegrator::pbar() const { return run_->pbar; }

void VariationalIntegrator::set_cotangent(const Coords& qbar, const Coords& pbar) {
  run_->qbar = qbar;
  run_->pbar = pbar;
}

VariationalIntegrator::Run& VariationalIntegrator::bound_run(Problem& problem, const char* caller) {
  if (!run_ || run_->problem != &problem)
    throw std::logic_error(std::string("VariationalIntegrator::") + caller + " before init() for this problem");
  return *run_;
}

Carried VariationalIntegrator::carried_state() const {
  Carried c;
  if (!run_) return c;
  const Run& run = *run_;
  c.put("qbar", run.qbar);
  c.put("pbar", run.pbar);
  run.predictor.save(c);
  c.put("plus_segment_v", run.equations.plus_segment().v);
  c.put("contraction", run.control.contraction());
  return c;
}

void VariationalIntegrator::restore(Problem& problem, const State& state, const Carried& c) {
  Run& run = bound_run(problem, "restore");
  const Eigen::Index n = run.q.cols();
  auto take = [&](const char* name, Coords& into) {
    Coords value = c.coords(name);
    if (value.cols() != n) throw std::invalid_argument(std::string("VariationalIntegrator::restore: ") + name);
    into = std::move(value);
  };
  take("qbar", run.qbar);
  take("pbar", run.pbar);
  run.predictor.restore(c);
  Segment& plus_segment = run.equations.plus_segment();
  take("plus_segment_v", plus_segment.v);
  run.control.set_contraction(c.number("contraction"));
  run.q = state.q;
  run.v = state.v;
  // The first stage's forces are those at q, which the State holds (as write_state put them).
  Forces& forces = plus_segment.stages[0].forces;
  forces.f = state.f;
  forces.potential = state.potential;
  forces.terms = state.energy_terms;
}

void VariationalIntegrator::write_state(const Run& run, State& state) const {
  const Forces& forces = run.equations.plus_segment().stages[0].forces;  // at exactly run.q
  state.q = run.q;
  state.v = run.v;
  state.f = forces.f;
  state.potential = forces.potential;
  state.energy_terms = forces.terms;
}

void VariationalIntegrator::init(Problem& problem, State& state) {
  check_start(problem, state);
  const int n = static_cast<int>(problem.inverse_mass.size());
  run_ = std::make_unique<Run>(problem, settings_);
  Run& run = *run_;
  VariationalEquations& equations = run.equations;
  const Eigen::VectorXd& inverse_mass = problem.inverse_mass;

  // The start is on TQ already (the engine constrains it, the same for every integrator): take it as it is.
  run.q = state.q;
  run.v = state.v;
  run.equations.dynamics().start_step(run.q);  // the pair set as a step from w₀ would fix it (see step())
  equations.evaluate_segments(run.q, run.v, state.step);

  // p⁺(w₀), p⁻(w₀) with w₀ fixed (docs/variational-integrator.md, "Initialisation"), by a plain
  // fixed-point iteration; tighter than the step tolerance: an error here offsets the whole trajectory.
  Coords p_minus(3, n), dp_plus(3, n), dp_minus(3, n);
  equations.initial_momenta(run.q, run.v, run.p_plus, p_minus);
  const double tolerance = std::max(1e-3 * settings_.tolerance, 1e-14);
  auto per_mass = [&](int i) { return inverse_mass[i]; };
  double err = std::numeric_limits<double>::infinity();
  int it = 0;
  while (err > tolerance) {
    if (it == std::max(settings_.max_iterations, 100))
      throw ConvergenceError("vi initialisation (momenta at the start)", state.step, it, err);
    ++it;
    equations.residual(run.q, run.v, run.p_plus, p_minus, state.step);
    equations.initial_momentum_corrections(dp_plus, dp_minus);
    parallel_assign(run.p_plus, run.p_plus + dp_plus);
    parallel_assign(p_minus, p_minus + dp_minus);
    err = std::max(max_abs_scaled(dp_plus, per_mass), max_abs_scaled(dp_minus, per_mass));
    equations.tangential_at_plus(run.p_plus);
    equations.tangential_at_minus(p_minus);
  }
  run.qbar = equations.x_plus();
  run.pbar = run.p_plus;
  equations.plus_segment_momentum(run.plus_segment_momentum);
  run.predictor.record_momentum(run.pbar, run.plus_segment_momentum);
  write_state(run, state);
}

void VariationalIntegrator::predict(Run& run, const State& state, long step) {
  run.equations.standard_step(state, run.qbar, step, run.q, run.v);
  run.predictor.begin_step(run.q, run.v);
  if (!run.predictor.corrects()) return;
  parallel_assign(run.q, run.q + run.predictor.q_offset());
  parallel_assign(run.v, run.v + run.predictor.v_offset());
  run.equations.return_to_tangent_bundle(run.q, run.v, run.qbar, step);
}

void VariationalIntegrator::evaluate(Run& run, int iteration, long step, const DynamicsPrecision& precision) {
  VariationalEquations& equations = run.equations;
  // Where q stays at q̄ through the step, the first stage's forces are computed once.
  const Forces* forces_at_q =
      equations.position_fixed() && iteration > 1 ? &equations.plus_segment().stages[0].forces : nullptr;
  equations.evaluate_segments(run.q, run.v, step, forces_at_q, /*plus_only=*/false, precision);
  if (iteration == 1)  // p⁺'s guess: M·V⁺ at the predicted w, corrected by the predictor
    parallel_assign(run.p_plus,
                    scaled_per_atom(run.problem->system.mass, equations.plus_segment().v) + run.predictor.p_offset());
  equations.tangential_at_plus(run.p_plus);
  equations.residual(run.q, run.v, run.p_plus, run.pbar, step, precision);
  equations.step_corrections(run.q, run.qbar, run.dq, run.dv, run.dp);
}

void VariationalIntegrator::update(Run& run, long step, double relaxation, bool mix) {
  VariationalEquations& equations = run.equations;
  if (relaxation < 1) {
    parallel_assign(run.dq, relaxation * run.dq);
    parallel_assign(run.dv, relaxation * run.dv);
    parallel_assign(run.dp, relaxation * run.dp);
    if (run.mixer) run.mixer->restart();  // the damped iterates do not follow the map T
  }
  // The plain update T: q ← P(q + δq), v ← M-orthogonal projection of v + δv at the new q, p⁺ ← p⁺ + δp.
  parallel_assign(run.q_trial, run.q + run.dq);
  parallel_assign(run.v_trial, run.v + run.dv);
  equations.return_to_tangent_bundle(run.q_trial, run.v_trial, run.qbar, step);
  if (!mix || !run.mixer || relaxation < 1) {
    parallel_assign(run.q, run.q_trial);
    parallel_assign(run.v, run.v_trial);
    parallel_assign(run.p_plus, run.p_plus + run.dp);
    return;
  }
  // Anderson mixing of T in x = (q/h, v, M⁻¹p⁺), so that the parts are comparable; then back onto TQ.
  const double h = settings_.dt;
  const Eigen::VectorXd& inverse_mass = run.problem->inverse_mass;
  run.mixer->record([&](int i, auto x, auto f) {
    x << run.q.col(i) / h, run.v.col(i), inverse_mass[i] * run.p_plus.col(i);
    f << (run.q_trial.col(i) - run.q.col(i)) / h, run.v_trial.col(i) - run.v.col(i), inverse_mass[i] * run.dp.col(i);
  });
  run.mixer->mix([&](int i, const Eigen::Matrix<double, kAndersonEntriesPerAtom, 1>& x) {
    run.q_trial.col(i) = h * x.segment<3>(0);
    run.v_trial.col(i) = x.segment<3>(3);
    // A virtual site (inverse mass 0) has no momentum.
    run.p_plus.col(i) = inverse_mass[i] > 0 ? Vec3(x.segment<3>(6) / inverse_mass[i]) : Vec3::Zero();
  });
  equations.return_to_tangent_bundle(run.q_trial, run.v_trial, run.qbar, step);
  parallel_assign(run.q, run.q_trial);
  parallel_assign(run.v, run.v_trial);
}

// How a solve ended: the controller's last verdict and the residual it leaves.
struct VariationalIntegrator::SolveOutcome {
  FixedPointControl::Verdict verdict;
  double residual;
};

StepReport VariationalIntegrator::step(Problem& problem, State& state) {
  Run& run = bound_run(problem, "step");
  const long step = state.step + 1;
  // One potential for the whole step where the force jumps at the cut-off: the pairs inside it at q̄
  // (known before the solve), each continued smoothly past the cut-off. The step's discrete
  // Lagrangian L_h,k is then smooth, so the iteration converges to any tolerance; the steps'
  // Lagrangians differ only by pairs at the cut-off. (Where the force is continuous there, the
  // true potential is kept: see ForceField::start_step.) The map (q̄_k, p̄_k) ↦ (q̄_k+1, p̄_k+1)
  // is still the one of a discrete Lagrangian (L_h,k for this step), hence symplectic, and V_k is
  // translation invariant, so Σ p̄ is conserved.
  run.equations.dynamics().start_step(run.qbar);
  predict(run, state, step);
  if (run.mixer) run.mixer->restart();
  run.control.begin(step_tolerance(run, state));
  const SolveOutcome outcome =
      solve(run, step, settings_.mixed_precision_solve && problem.force_field.has_single_precision());
  accept(run, outcome, state);
  return report(run, outcome);
}

double VariationalIntegrator::step_tolerance(const Run& run, const State& state) const {
  const double h = settings_.dt;
  // Updates below a few ulps of the positions (seen through /h) and velocities are round-off.
  const double round_off = 8 * std::numeric_limits<double>::epsilon() * (max_abs(state.q) / h + max_abs(state.v));
  double tolerance = settings_.tolerance;
  if (settings_.tolerance_from_offset) {
    const double offset = run.predictor.newest_offset_size(h);
    if (offset > 0) tolerance = VariationalSettings::kToleranceOfOffset * offset;
  }
  return std::max(tolerance, round_off);
}

VariationalIntegrator::SolveOutcome VariationalIntegrator::solve(Run& run, long step, bool mixed) {
  FixedPointControl& control = run.control;
  const double h = settings_.dt;
  double residual = std::numeric_limits<double>::infinity();
  FixedPointControl::Verdict verdict = FixedPointControl::Verdict::update;
  while (verdict == FixedPointControl::Verdict::update) {
    const int it = control.iterations() + 1;
    // Which evaluations may be single precision: see VariationalSettings::mixed_precision_solve.
    DynamicsPrecision precision;
    precision.single_stages = mixed && it == 1;
    precision.single_products =
        precision.single_stages || (mixed && control.tolerance() >= VariationalSettings::kSingleProductsMinTolerance);
    evaluate(run, it, step, precision);

    residual = std::max(max_abs(run.dv), max_abs(run.dq) / h);
    verdict = control.judge(residual, /*may_end=*/!precision.single_stages);
    switch (verdict) {
      case FixedPointControl::Verdict::update:
        update(run, step, control.relaxation(), /*mix=*/true);
        break;
      case FixedPointControl::Verdict::converged:
      case FixedPointControl::Verdict::settled_at_jump:
        break;
      case FixedPointControl::Verdict::converged_by_update:
        finish_by_update(run, step);
        residual = control.predicted_residual();
        break;
      case FixedPointControl::Verdict::not_finite:
        throw ConvergenceError("vi", step, it, residual, "the residual is not finite (the step is unstable; reduce dt)");
      case FixedPointControl::Verdict::exhausted:
        throw ConvergenceError("vi", step, it, residual,
                               std::string(control.relaxation() < 1
                                               ? "the residual stopped decreasing (a discontinuity in the forces "
                                                 "or their derivatives, or too large a step); "
                                               : "") +
                                   "raise max_iterations or solver_tolerance, or reduce dt (tolerance " +
                                   format_tolerance(control.tolerance()) + " nm/ps)");
    }
  }
  return {verdict, residual};
}

void VariationalIntegrator::finish_by_update(Run& run, long step) {
  VariationalEquations& equations = run.equations;
  // Spend only what the updated point's ∂⁺ needs (∂⁻ is not), no residual to confirm it.
  if (equations.position_fixed() && settings_.linear_final_segment) {
    parallel_assign(run.v_before_update, run.v);
    update(run, step, 1.0, /*mix=*/false);
    equations.advance_plus_segment_linearly(run.v, run.v_before_update, step);
  } else {
    update(run, step, 1.0, /*mix=*/false);
    equations.evaluate_segments(run.q, run.v, step,
                                equations.position_fixed() ? &equations.plus_segment().stages[0].forces : nullptr,
                                /*plus_only=*/true);
  }
}

void VariationalIntegrator::accept(Run& run, const SolveOutcome& outcome, State& state) const {
  VariationalEquations& equations = run.equations;
  // Accept w: (q̄, p̄) ← (∂⁺(w), tangential part at ∂⁺(w) of p⁺ (+ δp when w was evaluated)).
  parallel_assign(run.qbar, equations.x_plus());
  if (outcome.verdict == FixedPointControl::Verdict::converged_by_update)
    parallel_assign(run.pbar, run.p_plus);
  else
    parallel_assign(run.pbar, run.p_plus + run.dp);
  equations.tangential_at_plus(run.pbar);
  equations.plus_segment_momentum(run.plus_segment_momentum);
  run.predictor.record(run.q, run.v, run.pbar, run.plus_segment_momentum);
  write_state(run, state);
}

StepReport VariationalIntegrator::report(const Run& run, const SolveOutcome& outcome) const {
  StepReport out;
  out.iterations = run.control.iterations();
  out.residual = outcome.residual;
  const Vec3 momentum = run.pbar.rowwise().sum();
  out.diagnostics = {static_cast<double>(out.iterations), outcome.residual,
                     outcome.verdict == FixedPointControl::Verdict::settled_at_jump ? 1.0 : 0.0,
                     momentum.x(), momentum.y(), momentum.z()};
  if (settings_.tolerance_from_offset) out.diagnostics.push_back(run.control.tolerance());
  return out;
}

}  // namespace vimd
