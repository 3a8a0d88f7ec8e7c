#include "integrators/variational.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "engine/errors.hpp"
#include "integrators/constrained_dynamics.hpp"
#include "integrators/coords_ops.hpp"
#include "integrators/explicit_rk.hpp"
#include "integrators/projection.hpp"
#include "integrators/thermostat.hpp"
#include "integrators/verlet.hpp"

namespace vimd {

namespace {

constexpr int kMaxAndersonDepth = 8;
constexpr int kMaxPredictorHistory = 3;
// Relaxation control of the step iteration (see step()).
constexpr double kNoProgress = 0.95;
constexpr double kMinRelaxation = 1.0 / 1024;
constexpr double kJumpFactor = 100;

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
    throw InputError(file, 0, "solver_tolerance must be positive (nm/ps), got " + format_tolerance(*config.solver_tolerance));
  VariationalSettings s;
  s.plus = resolve_tableau(config.method, config, file);
  s.minus = config.method_minus ? resolve_tableau(*config.method_minus, config, file) : s.plus;
  s.dt = config.dt;
  s.alpha_minus = config.bias[0];
  s.alpha_plus = config.bias[1];
  if (!(s.alpha_minus >= -1 && s.alpha_minus <= 0 && s.alpha_plus >= 0 && s.alpha_plus <= 1) ||
      std::abs(s.alpha_plus - s.alpha_minus - 1) > 1e-12)
    throw InputError(file, 0,
                     "bias = [" + std::to_string(s.alpha_minus) + ", " + std::to_string(s.alpha_plus) +
                         "] must satisfy -1 <= alpha_minus <= 0 <= alpha_plus <= 1 and alpha_plus - alpha_minus = 1");
  check_projection_kind(config.projection);
  s.projection = config.projection;
  s.tolerance = config.solver_tolerance ? *config.solver_tolerance : default_solver_tolerance(s.alpha_minus);
  s.max_iterations = config.max_iterations;
  if (config.acceleration == "anderson")
    s.anderson_depth = 4;
  else if (config.acceleration != "none")
    throw InputError(file, 0, "acceleration must be \"none\" or \"anderson\", not \"" + config.acceleration + "\"");
  if (config.solver_precision != "mixed" && config.solver_precision != "double")
    throw InputError(file, 0, "solver_precision must be \"mixed\" or \"double\", not \"" + config.solver_precision + "\"");
  s.mixed_precision_solve = config.solver_precision == "mixed";
  return s;
}

int VariationalSettings::predictor_history_used() const {
  if (predictor_history != kAutomaticHistory) return predictor_history;
  return alpha_minus == 0 ? kMaxPredictorHistory : 1;
}

double default_solver_tolerance(double alpha_minus) {
  // Calibrated by validation/bench_vi (901 SPC/E waters, 2 fs, LJ potential-switch + reaction field,
  // rk4): with bias [0, 1], 1e-6 nm/ps matches 1e-8 in energy fluctuation and drift within 2%
  // (1e-5 does not: drift 24% off); with α⁻ < 0 the two segments' errors add and 1e-6 moves the
  // drift by 17% against 1e-8, so 1e-7. Lower-order methods have larger truncation errors, so the
  // same values are safe for them.
  return alpha_minus == 0 ? 1e-6 : 1e-7;
}

// Everything a run needs, built at init() for its Problem; sized once so steps do not allocate.
struct VariationalIntegrator::Work {
  Problem* problem;
  ConstrainedDynamics dynamics;
  ExplicitRungeKutta plus, minus;
  Projection projection;
  TangentProjector euclid_q, euclid_plus, euclid_minus, mass_q;
  Segment seg_plus, seg_minus, seg_predict;
  ProjectedPoint proj_plus, proj_minus, proj_q;
  Coords q, v, p_plus;          // the unknowns
  Coords qbar, pbar;            // the cotangent state
  Coords q_standard, v_standard;  // this step's standard-layer prediction
  // Per accepted point, newest first: solution minus standard-layer prediction (q, v), and
  // p̄ − Π(M·V⁺) with Π tangential at ∂⁺ (p); and this step's extrapolation of them.
  struct Offsets {
    Coords q, v, p;
  };
  std::array<Offsets, kMaxPredictorHistory> offsets;
  int offsets_recorded = 0;
  Offsets predicted;
  Coords rho_q, rho_v, minus_q, minus_v, p_hat;
  Coords dq, dv, dp, trial, v_trial, start_direction, v_previous;
  Eigen::VectorXd nu;
  // Anderson history: per atom (q/h, v, M⁻¹p) and the fixed-point residual in the same scaling.
  std::vector<Eigen::Matrix<double, 9, Eigen::Dynamic>> history_x, history_f;
  int history_start = 0;  // iteration after which the current Anderson history began
  double contraction = 1;  // largest contraction factor of the last step's iteration (1: unknown)

  Work(Problem& p, const VariationalSettings& s)
      : problem(&p),
        dynamics(p),
        plus(s.plus),
        minus(s.minus),
        projection(p.constraints, p.inverse_mass, s.projection),
        euclid_q(p.constraints, Eigen::VectorXd::Ones(p.inverse_mass.size())),
        euclid_plus(p.constraints, Eigen::VectorXd::Ones(p.inverse_mass.size())),
        euclid_minus(p.constraints, Eigen::VectorXd::Ones(p.inverse_mass.size())),
        mass_q(p.constraints, p.inverse_mass) {
    // The solve needs forces alone; the state (a segment start) gets its energies when they are due.
    dynamics.set_energies(ConstrainedDynamics::Energies::at_due_starts);
    const int n = static_cast<int>(p.inverse_mass.size());
    for (Coords* c : {&q, &v, &p_plus, &qbar, &pbar, &rho_q, &rho_v, &minus_q, &minus_v, &p_hat, &dq, &dv, &dp, &trial,
                      &v_trial, &start_direction, &v_previous, &q_standard, &v_standard})
      c->setZero(3, n);
    auto zero = [n](Offsets& o) {
      for (Coords* c : {&o.q, &o.v, &o.p}) c->setZero(3, n);
    };
    for (Offsets& o : offsets) zero(o);
    zero(predicted);
    history_x.assign(s.anderson_depth > 0 ? s.anderson_depth + 1 : 0, Eigen::Matrix<double, 9, Eigen::Dynamic>(9, n));
    history_f = history_x;
  }
};

VariationalIntegrator::VariationalIntegrator(VariationalSettings settings) : settings_(std::move(settings)) {
  if (settings_.anderson_depth < 0 || settings_.anderson_depth > kMaxAndersonDepth)
    throw std::invalid_argument("Anderson depth must be between 0 and " + std::to_string(kMaxAndersonDepth));
  if (settings_.predictor_history < VariationalSettings::kAutomaticHistory ||
      settings_.predictor_history > kMaxPredictorHistory)
    throw std::invalid_argument("predictor history must be between 0 and " + std::to_string(kMaxPredictorHistory) +
                                ", or automatic");
}
VariationalIntegrator::VariationalIntegrator(const IntegratorConfig& config)
    : VariationalIntegrator(VariationalSettings::from_config(config)) {}
VariationalIntegrator::~VariationalIntegrator() = default;

std::vector<std::string> VariationalIntegrator::diagnostic_names() const {
  return {"vi_iterations", "vi_residual", "vi_jump", "noether_px", "noether_py", "noether_pz"};
}

const Coords& VariationalIntegrator::qbar() const { return work_->qbar; }
const Coords& VariationalIntegrator::pbar() const { return work_->pbar; }

Carried VariationalIntegrator::carried_state() const {
  Carried c;
  if (!work_) return c;
  const Work& w = *work_;
  c.put("qbar", w.qbar);
  c.put("pbar", w.pbar);
  for (int k = 0; k < w.offsets_recorded; ++k) {
    const std::string age = std::to_string(k);
    c.put("q_offset_" + age, w.offsets[k].q);
    c.put("v_offset_" + age, w.offsets[k].v);
    c.put("p_offset_" + age, w.offsets[k].p);
  }
  c.put("offsets_recorded", w.offsets_recorded);
  c.put("plus_segment_v", w.seg_plus.v);
  c.put("contraction", w.contraction);
  return c;
}

void VariationalIntegrator::restore(Problem& problem, const State& state, const Carried& c) {
  Work& w = work(problem, "restore");
  const Eigen::Index n = w.q.cols();
  auto take = [&](const char* name, Coords& into) {
    Coords value = c.coords(name);
    if (value.cols() != n) throw std::invalid_argument(std::string("VariationalIntegrator::restore: ") + name);
    into = std::move(value);
  };
  take("qbar", w.qbar);
  take("pbar", w.pbar);
  const double recorded = c.number("offsets_recorded");
  if (!(recorded >= 0 && recorded <= kMaxPredictorHistory))
    throw std::invalid_argument("VariationalIntegrator::restore: offsets_recorded");
  w.offsets_recorded = static_cast<int>(recorded);
  for (int k = 0; k < w.offsets_recorded; ++k) {
    const std::string age = std::to_string(k);
    take(("q_offset_" + age).c_str(), w.offsets[k].q);
    take(("v_offset_" + age).c_str(), w.offsets[k].v);
    take(("p_offset_" + age).c_str(), w.offsets[k].p);
  }
  take("plus_segment_v", w.seg_plus.v);
  w.contraction = c.number("contraction");
  w.q = state.q;
  w.v = state.v;
  // The first stage's forces are those at q, which the State holds (as write_state put them).
  Forces& forces = w.seg_plus.stages[0].forces;
  forces.f = state.f;
  forces.potential = state.potential;
  forces.terms = state.energy_terms;
}

void VariationalIntegrator::set_cotangent(const Coords& qbar, const Coords& pbar) {
  work_->qbar = qbar;
  work_->pbar = pbar;
}

VariationalIntegrator::Work& VariationalIntegrator::work(Problem& problem, const char* caller) {
  if (!work_ || work_->problem != &problem)
    throw std::logic_error(std::string("VariationalIntegrator::") + caller + " before init() for this problem");
  return *work_;
}

void VariationalIntegrator::forward_segments(Work& w, const Coords& q, const Coords& v, long step,
                                             const Forces* forces_at_q, bool plus_only) {
  const double h = settings_.dt;
  w.plus.forward(w.dynamics, q, v, h * settings_.alpha_plus, w.seg_plus, forces_at_q);
  w.projection.project(w.seg_plus.q, w.proj_plus, step);
  if (settings_.alpha_minus != 0 && !plus_only) {
    // Both segments start at w: the first stage's forces are shared.
    w.minus.forward(w.dynamics, q, v, h * settings_.alpha_minus, w.seg_minus, &w.seg_plus.stages[0].forces);
    w.projection.project(w.seg_minus.q, w.proj_minus, step);
  }
}

// r = (−p̂⁺, 0, +1)·DΦ_{τ⁺} + (p̂⁻, 0, −1)·DΦ_{τ⁻}  (or + (p⁻, 0) when τ⁻ = 0), then
// ν = (GGᵀ)⁻¹G r_v, ρ_v = r_v − Gᵀν, ρ_q = Π(r_q − Ġᵀν), all at q; into w.rho_q, w.rho_v.
void VariationalIntegrator::residual(Work& w, const Coords& q, const Coords& v, const Coords& p_plus,
                                     const Coords& p_minus, long step) {
  const int n = static_cast<int>(q.cols());
  w.projection.pull_back(w.proj_plus, p_plus, w.p_hat, step);
  parallel_assign(w.p_hat, -w.p_hat);
  if (settings_.alpha_minus != 0) {
    // Both segments start at q: one Hessian–vector product there serves both reverse passes.
    w.start_direction.setZero();
    w.plus.vjp(w.dynamics, w.seg_plus, w.p_hat, nullptr, 1.0, w.rho_q, w.rho_v, &w.start_direction);
    w.projection.pull_back(w.proj_minus, p_minus, w.p_hat, step);
    w.minus.vjp(w.dynamics, w.seg_minus, w.p_hat, nullptr, -1.0, w.minus_q, w.minus_v, &w.start_direction);
    w.dynamics.hessian_vector(q, w.start_direction, w.p_hat, &w.seg_plus.stages[0].forces);
    for_each_atom(n, [&](int i) {
      w.rho_q.col(i) += w.minus_q.col(i) - w.p_hat.col(i);
      w.rho_v.col(i) += w.minus_v.col(i);
    });
  } else {
    w.plus.vjp(w.dynamics, w.seg_plus, w.p_hat, nullptr, 1.0, w.rho_q, w.rho_v);
    parallel_assign(w.rho_q, w.rho_q + p_minus);
  }
  const Constraints& c = w.problem->constraints;
  if (c.empty()) return;
  w.euclid_q.set_point(q);
  w.euclid_q.apply(w.rho_v, &w.nu);
  w.nu = -w.nu;
  c.add_H(w.nu, v, w.rho_q);
  w.euclid_q.apply(w.rho_q);
}

// The momentum offset is p̄ − Π(M V⁺) at the accepted point, both tangent at q̄ = ∂⁺(w). Its
// normal part would be rotated into the tangent space at the next ∂⁺ and spoil the prediction, hence Π.
void VariationalIntegrator::record_offsets(Work& w, bool with_state) const {
  std::rotate(w.offsets.rbegin(), w.offsets.rbegin() + 1, w.offsets.rend());  // swaps storage, copies nothing
  w.offsets_recorded = std::min(w.offsets_recorded + 1, kMaxPredictorHistory);
  Work::Offsets& newest = w.offsets[0];
  const Eigen::VectorXd& mass = w.problem->system.mass;
  for_each_atom(static_cast<int>(w.q.cols()), [&](int i) { newest.p.col(i) = mass[i] * w.seg_plus.v.col(i); });
  w.euclid_plus.apply(newest.p);
  parallel_assign(newest.p, w.pbar - newest.p);
  if (with_state) {
    parallel_assign(newest.q, w.q - w.q_standard);
    parallel_assign(newest.v, w.v - w.v_standard);
  } else {
    newest.q.setZero();
    newest.v.setZero();
  }
}

// A polynomial through the last offsets predicts the next one a little better than the last alone:
// they change by most of their size from step to step (at the pace of the fastest motion), but on
// water900 at [0,1] the first residual still falls by ~15%, enough to spare most steps a third
// iteration (see VariationalSettings::predictor_history for where it does not pay).
void VariationalIntegrator::extrapolate_offsets(Work& w) const {
  static constexpr double kWeights[kMaxPredictorHistory][kMaxPredictorHistory] = {
      {1, 0, 0}, {2, -1, 0}, {3, -3, 1}};
  const int used = std::min(w.offsets_recorded, settings_.predictor_history_used());
  Work::Offsets& out = w.predicted;
  if (used == 0) {
    for (Coords* c : {&out.q, &out.v, &out.p}) c->setZero();
    return;
  }
  const double* c = kWeights[used - 1];
  const auto& o = w.offsets;
  for_each_atom(static_cast<int>(w.q.cols()), [&](int i) {
    out.q.col(i) = c[0] * o[0].q.col(i);
    out.v.col(i) = c[0] * o[0].v.col(i);
    out.p.col(i) = c[0] * o[0].p.col(i);
    for (int k = 1; k < used; ++k) {
      out.q.col(i) += c[k] * o[k].q.col(i);
      out.v.col(i) += c[k] * o[k].v.col(i);
      out.p.col(i) += c[k] * o[k].p.col(i);
    }
  });
}

void VariationalIntegrator::write_state(Work& w, State& state) const {
  const Forces& forces = w.seg_plus.stages[0].forces;  // at exactly w.q
  state.q = w.q;
  state.v = w.v;
  state.f = forces.f;
  state.potential = forces.potential;
  state.energy_terms = forces.terms;
}

void VariationalIntegrator::init(Problem& problem, State& state) {
  check_start(problem, state);
  const int n = static_cast<int>(problem.inverse_mass.size());
  work_ = std::make_unique<Work>(problem, settings_);
  Work& w = *work_;
  const double h = settings_.dt, tau_minus = h * settings_.alpha_minus;
  const Eigen::VectorXd& mass = problem.system.mass;
  const Eigen::VectorXd& inverse_mass = problem.inverse_mass;

  // The start is on TQ already (the engine constrains it, the same for every integrator): take it as it is.
  w.q = state.q;
  w.v = state.v;
  w.dynamics.start_step(w.q);  // the pair set as a step from w₀ would fix it (see step())
  forward_segments(w, w.q, w.v, state.step);

  // p⁺(w₀), p⁻(w₀) with w₀ fixed: the same residual, p̄ replaced by the unknown p⁻ (spec §6, init).
  Coords& p_minus = w.trial;
  for_each_atom(n, [&](int i) { w.p_plus.col(i) = mass[i] * w.v.col(i); });
  p_minus = w.p_plus;
  w.euclid_plus.set_point(w.proj_plus.x);
  w.euclid_plus.apply(w.p_plus);
  w.euclid_minus.set_point(settings_.alpha_minus != 0 ? w.proj_minus.x : w.q);
  w.euclid_minus.apply(p_minus);
  // Tighter than the step tolerance: an error here offsets the whole trajectory.
  const double tolerance = std::max(1e-3 * settings_.tolerance, 1e-14);
  double err = std::numeric_limits<double>::infinity();
  int it = 0;
  while (err > tolerance) {
    if (it == std::max(settings_.max_iterations, 100))
      throw ConvergenceError("vi initialisation (momenta at the start)", state.step, it, err);
    ++it;
    residual(w, w.q, w.v, w.p_plus, p_minus, state.step);
    // δp⁺ = (ρ_v − τ⁻ρ_q)/h, δp⁻ = δp⁺ − ρ_q
    for_each_atom(n, [&](int i) {
      w.dp.col(i) = (w.rho_v.col(i) - tau_minus * w.rho_q.col(i)) / h;
      w.dv.col(i) = w.dp.col(i) - w.rho_q.col(i);
      w.p_plus.col(i) += w.dp.col(i);
      p_minus.col(i) += w.dv.col(i);
    });
    auto per_mass = [&](int i) { return inverse_mass[i]; };
    err = std::max(max_abs_scaled(w.dp, per_mass), max_abs_scaled(w.dv, per_mass));
    w.euclid_plus.apply(w.p_plus);
    w.euclid_minus.apply(p_minus);
  }
  w.qbar = w.proj_plus.x;
  w.pbar = w.p_plus;
  record_offsets(w, /*with_state=*/false);
  write_state(w, state);
}

void VariationalIntegrator::predict(Work& w, const State& state, long step) {
  const double h = settings_.dt;
  if (settings_.alpha_minus == 0) {
    // ∂⁻(w) = q, so q = q̄ exactly; the accepted ∂⁺ segment is the standard step Φ_h(w_k).
    parallel_assign(w.q, w.qbar);
    parallel_assign(w.v, w.seg_plus.v);
  } else {
    // The standard layer's own step Φ_h(w_k), its first stage shared with the accepted segments.
    w.plus.forward(w.dynamics, state.q, state.v, h, w.seg_predict, &w.seg_plus.stages[0].forces);
    w.projection.project(w.seg_predict.q, w.proj_q, step);
    parallel_assign(w.q, w.proj_q.x);
    parallel_assign(w.v, w.seg_predict.v);
  }
  w.mass_q.set_point(w.q);
  w.mass_q.apply(w.v);
  parallel_assign(w.q_standard, w.q);
  parallel_assign(w.v_standard, w.v);
  // The solution differs from the standard step by a smooth O(h^{p+1}) amount: add its extrapolation.
  extrapolate_offsets(w);
  if (w.offsets_recorded == 0 || settings_.predictor_history_used() == 0) return;
  if (settings_.alpha_minus != 0) {
    parallel_assign(w.trial, w.q + w.predicted.q);
    w.projection.project(w.trial, w.proj_q, step);
    parallel_assign(w.q, w.proj_q.x);
    w.mass_q.set_point(w.q);
  }
  parallel_assign(w.v, w.v + w.predicted.v);
  w.mass_q.apply(w.v);
}

// With α⁻ = 0 the final update changes v alone (q = q̄), by Δv = v − v_previous, small as the
// tolerance over the contraction factor. Its ∂⁺ segment to first order, with the solver's own
// approximate Jacobian (∂Q⁺/∂v ≈ τ⁺, ∂V⁺/∂v ≈ 1): Q⁺ += τ⁺Δv, V⁺ += Δv, then x⁺ = P(Q⁺). The
// neglected terms, O((τ⁺)²(ω² + |∂A/∂v|))·τ⁺|Δv|, are a few per cent of the τ⁺·tolerance that
// the solve leaves in x⁺ anyway on water at 2 fs; the forward pass it replaces costs s − 1 force
// evaluations. The stages stay those of the last evaluated point: only the first one (at q, the
// same) is read again.
void VariationalIntegrator::advance_plus_segment_linearly(Work& w, long step) {
  const double tau_plus = settings_.dt * settings_.alpha_plus;
  for_each_atom(static_cast<int>(w.q.cols()), [&](int i) {
    const Vec3 dv = w.v.col(i) - w.v_previous.col(i);
    w.seg_plus.q.col(i) += tau_plus * dv;
    w.seg_plus.v.col(i) += dv;
  });
  w.projection.project(w.seg_plus.q, w.proj_plus, step);
}

void VariationalIntegrator::update(Work& w, int iteration, long step, double relaxation, bool plain) {
  const int n = static_cast<int>(w.q.cols());
  const double h = settings_.dt;
  const Eigen::VectorXd& inverse_mass = w.problem->inverse_mass;
  if (relaxation < 1) {
    for_each_atom(n, [&](int i) {
      w.dq.col(i) *= relaxation;
      w.dv.col(i) *= relaxation;
      w.dp.col(i) *= relaxation;
    });
    w.history_start = iteration;  // Anderson restarts after damping
  }
  // The plain update: q ← P(q + δq), v ← M-orthogonal projection of v + δv at the new q, p⁺ ← p⁺ + δp.
  auto settle = [&](Coords& q_trial, Coords& v_trial) {
    if (settings_.alpha_minus == 0) {
      // ∂⁻(w) = q: the position equation holds exactly with q = q̄ (and the tangent projector
      // is already there), so the forces at q stay valid through the iteration.
      parallel_assign(q_trial, w.qbar);
    } else {
      w.projection.project(q_trial, w.proj_q, step);
      parallel_assign(q_trial, w.proj_q.x);
      w.mass_q.set_point(q_trial);
    }
    w.mass_q.apply(v_trial);
  };
  parallel_assign(w.trial, w.q + w.dq);
  parallel_assign(w.v_trial, w.v + w.dv);
  settle(w.trial, w.v_trial);
  const int depth = settings_.anderson_depth;
  if (depth == 0 || relaxation < 1 || plain) {
    parallel_assign(w.q, w.trial);
    parallel_assign(w.v, w.v_trial);
    parallel_assign(w.p_plus, w.p_plus + w.dp);
    return;
  }
  // Anderson mixing of the map T(x) = plain update of x, in x = (q/h, v, M⁻¹p) so the parts are
  // comparable: with f = T(x) − x, x ← T(x) − Σ_j γ_j (Δx_j + Δf_j), γ = argmin ‖f − Σ_j γ_j Δf_j‖,
  // where Δ·_j = ·_k − ·_{k−j} over the last `depth` iterates. Then back onto TQ.
  const int slots = depth + 1;
  const int count = iteration - w.history_start;  // iterates in the current Anderson history
  const int k = (count - 1) % slots;
  auto slot = [&](int j) { return ((k - j) % slots + slots) % slots; };
  auto& xk = w.history_x[k];
  auto& fk = w.history_f[k];
  for_each_atom(n, [&](int i) {
    xk.col(i) << w.q.col(i) / h, w.v.col(i), inverse_mass[i] * w.p_plus.col(i);
    fk.col(i) << (w.trial.col(i) - w.q.col(i)) / h, w.v_trial.col(i) - w.v.col(i), inverse_mass[i] * w.dp.col(i);
  });
  const int m = std::min(count, slots) - 1;
  Eigen::Matrix<double, kMaxAndersonDepth, 1> gamma = Eigen::Matrix<double, kMaxAndersonDepth, 1>::Zero();
  if (m > 0) {
    Eigen::Matrix<double, kMaxAndersonDepth, kMaxAndersonDepth> gram;
    Eigen::Matrix<double, kMaxAndersonDepth, 1> rhs;
    for (int a = 1; a <= m; ++a) {
      const auto& fa = w.history_f[slot(a)];
      for (int b = a; b <= m; ++b) {
        const auto& fb = w.history_f[slot(b)];
        double s = 0;
#pragma omp parallel for schedule(static) reduction(+ : s) if (n >= kParallelMinAtoms)
        for (int i = 0; i < n; ++i) s += (fk.col(i) - fa.col(i)).dot(fk.col(i) - fb.col(i));
        gram(a - 1, b - 1) = gram(b - 1, a - 1) = s;
      }
      double s = 0;
#pragma omp parallel for schedule(static) reduction(+ : s) if (n >= kParallelMinAtoms)
      for (int i = 0; i < n; ++i) s += (fk.col(i) - fa.col(i)).dot(fk.col(i));
      rhs(a - 1) = s;
    }
    // Regularised normal equations of a tiny least-squares problem (m ≤ kMaxAndersonDepth).
    Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, kMaxAndersonDepth, kMaxAndersonDepth> a =
        gram.topLeftCorner(m, m);
    a.diagonal().array() += 1e-10 * a.trace() + std::numeric_limits<double>::min();
    gamma.head(m) = a.ldlt().solve(rhs.head(m));
  }
  for_each_atom(n, [&](int i) {
    Eigen::Matrix<double, 9, 1> x = xk.col(i) + fk.col(i);
    for (int j = 1; j <= m; ++j)
      x -= gamma(j - 1) * (xk.col(i) - w.history_x[slot(j)].col(i) + fk.col(i) - w.history_f[slot(j)].col(i));
    w.trial.col(i) = h * x.segment<3>(0);
    w.v_trial.col(i) = x.segment<3>(3);
    w.p_plus.col(i) = x.segment<3>(6) / inverse_mass[i];
  });
  settle(w.trial, w.v_trial);
  parallel_assign(w.q, w.trial);
  parallel_assign(w.v, w.v_trial);
}

StepReport VariationalIntegrator::step(Problem& problem, State& state) {
  Work& w = work(problem, "step");
  const int n = static_cast<int>(w.q.cols());
  const long step = state.step + 1;
  const double h = settings_.dt, tau_plus = h * settings_.alpha_plus, tau_minus = h * settings_.alpha_minus;
  const Eigen::VectorXd& mass = problem.system.mass;
  const Eigen::VectorXd& inverse_mass = problem.inverse_mass;

  // One potential for the whole step where the force jumps at the cut-off: the pairs inside it at q̄
  // (known before the solve), each continued smoothly past the cut-off. The step's discrete
  // Lagrangian L_h,k is then smooth, so the iteration converges to any tolerance; the steps'
  // Lagrangians differ only by pairs at the cut-off. (Where the force is continuous there, the
  // true potential is kept: see ForceField::start_step.) The map (q̄_k, p̄_k) ↦ (q̄_k+1, p̄_k+1)
  // is still the one of a discrete Lagrangian (L_h,k for this step), hence symplectic, and V_k is
  // translation invariant, so Σ p̄ is conserved.
  w.dynamics.start_step(w.qbar);
  predict(w, state, step);
  w.history_start = 0;
  // Updates below a few ulps of the positions (seen through /h) and velocities are round-off.
  const double round_off = 8 * std::numeric_limits<double>::epsilon() * (max_abs(state.q) / h + max_abs(state.v));
  const double tolerance = std::max(settings_.tolerance, round_off);
  double err = std::numeric_limits<double>::infinity(), previous = err, before_previous = err;
  const bool mixed = settings_.mixed_precision_solve && problem.force_field.has_single_precision();
  // Relaxation of the update, halved while the residual stops decreasing. The residual jumps where
  // a pair crosses the cut-off inside a stage (the reaction field's second derivative, or an
  // unsmoothed force, is discontinuous there); then no root exists, the plain iteration cycles
  // across the jump, and the damped one settles on it.
  double relaxation = 1;
  bool settled_at_jump = false;
  // Largest contraction factor err_k/err_{k−1} seen in this step; the estimate for predicted
  // stops is the larger of it and the last step's.
  double contraction = 0;
  bool finished_by_update = false;
  int it = 0;
  for (;;) {
    ++it;
    // See VariationalSettings::mixed_precision_solve.
    const bool single = mixed && it == 1;
    w.dynamics.set_single_precision_stages(single);
    w.dynamics.set_single_precision_products(single ||
                                             (mixed && tolerance >= VariationalSettings::kSingleProductsMinTolerance));
    // With α⁻ = 0, q = q̄ throughout the step: the first stage's forces are computed once.
    forward_segments(w, w.q, w.v, step, settings_.alpha_minus == 0 && it > 1 ? &w.seg_plus.stages[0].forces : nullptr);
    if (it == 1) {
      for_each_atom(n, [&](int i) { w.p_plus.col(i) = mass[i] * w.seg_plus.v.col(i) + w.predicted.p.col(i); });
    }
    w.euclid_plus.set_point(w.proj_plus.x);
    w.euclid_plus.apply(w.p_plus);
    residual(w, w.q, w.v, w.p_plus, w.pbar, step);
    w.dynamics.set_single_precision_stages(false);
    w.dynamics.set_single_precision_products(false);
    const Coords& x_minus = settings_.alpha_minus != 0 ? w.proj_minus.x : w.q;
    // δp = ρ_q,  δv = M⁻¹(τ⁺ρ_q − ρ_v)/h,  δq = −(∂⁻(w) − q̄) − τ⁻δv
    for_each_atom(n, [&](int i) {
      w.dp.col(i) = w.rho_q.col(i);
      w.dv.col(i) = inverse_mass[i] * (tau_plus * w.rho_q.col(i) - w.rho_v.col(i)) / h;
      w.dq.col(i) = w.qbar.col(i) - x_minus.col(i) - tau_minus * w.dv.col(i);
    });
    err = std::max(max_abs(w.dv), max_abs(w.dq) / h);
    if (!std::isfinite(err))
      throw ConvergenceError("vi", step, it, err, "the residual is not finite (the step is unstable; reduce dt)");
    if (err <= tolerance && !single) break;
    if (it > 1) contraction = std::max(contraction, err / previous);
    // No progress over two iterations (the plain iteration's convergence is not monotone, a
    // cycle across a jump repeats every other iteration): damp; good progress: undamp.
    if (err > kNoProgress * before_previous)
      relaxation = std::max(0.5 * relaxation, kMinRelaxation);
    else if (err < 0.5 * previous)
      relaxation = std::min(2 * relaxation, 1.0);
    // Settled on a jump: the iterate moves by less than the tolerance while the residual, which
    // cannot vanish there, stays within kJumpFactor of it.
    if (relaxation < 1 && relaxation * err <= tolerance && err <= kJumpFactor * tolerance) {
      settled_at_jump = true;
      break;
    }
    if (it >= settings_.max_iterations)
      throw ConvergenceError("vi", step, it, err,
                             std::string(relaxation < 1 ? "the residual stopped decreasing (a discontinuity in the forces "
                                                          "or their derivatives, or too large a step); "
                                                        : "") +
                                 "raise max_iterations or solver_tolerance, or reduce dt (tolerance " +
                                 format_tolerance(tolerance) + " nm/ps)");
    before_previous = previous;
    previous = err;
    if (settings_.predicted_stop && it > 1 && relaxation == 1 &&
        std::max(contraction, w.contraction) * err <= tolerance) {
      // The update lands within contraction·err ≤ tolerance of the solution: take it, and spend
      // only what the new point's ∂⁺ needs (∂⁻ is not), no residual to confirm it.
      if (settings_.alpha_minus == 0 && settings_.linear_final_segment) {
        parallel_assign(w.v_previous, w.v);
        update(w, it, step, 1.0, /*plain=*/true);
        advance_plus_segment_linearly(w, step);
      } else {
        update(w, it, step, 1.0, /*plain=*/true);
        forward_segments(w, w.q, w.v, step, settings_.alpha_minus == 0 ? &w.seg_plus.stages[0].forces : nullptr,
                         /*plus_only=*/true);
      }
      w.euclid_plus.set_point(w.proj_plus.x);
      err *= std::max(contraction, w.contraction);
      finished_by_update = true;
      break;
    }
    update(w, it, step, relaxation);
  }
  if (it > 1) w.contraction = std::min(contraction, 1.0);

  // Accept w: (q̄, p̄) ← (∂⁺(w), tangential part at ∂⁺(w) of p⁺ (+ δp when w was evaluated).
  parallel_assign(w.qbar, w.proj_plus.x);
  if (finished_by_update)
    parallel_assign(w.pbar, w.p_plus);
  else
    parallel_assign(w.pbar, w.p_plus + w.dp);
  w.euclid_plus.apply(w.pbar);
  record_offsets(w, /*with_state=*/true);
  write_state(w, state);

  StepReport report;
  report.iterations = it;
  report.residual = err;
  const Vec3 momentum = w.pbar.rowwise().sum();
  report.diagnostics = {static_cast<double>(it), err, settled_at_jump ? 1.0 : 0.0, momentum.x(), momentum.y(),
                        momentum.z()};
  return report;
}

}  // namespace vimd
