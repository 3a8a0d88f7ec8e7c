#include "engine/simulation.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <type_traits>

#include "simd/atom_kernels.hpp"
#include "engine/errors.hpp"
#include "engine/start_state.hpp"
#include "engine/stop.hpp"

namespace vimd {

Simulation::Simulation(Problem& problem, Integrator& integrator, double dt)
    : problem_(problem), integrator_(integrator), dt_(dt) {}

void Simulation::add_observer(std::unique_ptr<Observer> observer) { observers_.push_back(std::move(observer)); }

Sample Simulation::sample(const State& state, const StepReport& report) const {
  const System& system = problem_.system;
  Sample s;
  s.step = state.step;
  s.time = state.time;
  s.potential = state.potential;
  s.kinetic = integrator_.kinetic_energy(problem_, state);
  s.total = s.potential + s.kinetic;
  s.conserved = s.total - integrator_.thermostat_work();
  const int dof = system.degrees_of_freedom();
  s.temperature = dof > 0 ? 2.0 * s.kinetic / (dof * kBoltzmann) : 0.0;
  s.energy_terms = state.energy_terms;
  s.momentum = state.v * system.mass;
  s.diagnostics = report.diagnostics;
  if (!problem_.constraints.empty()) {
    Eigen::VectorXd g;
    problem_.constraints.residuals(state.q, g);
    double sum = 0;
    const auto& list = problem_.constraints.list();
    for (int a = 0; a < g.size(); ++a) {
      // g = ½(r² − d²) ≈ d (r − d): relative length deviation ≈ g / d²
      const double rel = g[a] / (list[a].length * list[a].length);
      sum += rel * rel;
    }
    s.constraint_rms = std::sqrt(sum / g.size());
  }
  return s;
}

namespace {

// Beyond these a state is not physics any more: an H atom under 1e6 kJ/mol/nm moves 2 nm in a 2 fs
// step; 1e3 nm/ps is ~300 times the thermal speed of H at 1000 K.
constexpr double kAbsurdForce = 1e6;     // kJ/mol/nm
constexpr double kAbsurdVelocity = 1e3;  // nm/ps
constexpr double kAbsurdPosition = 1e6;  // nm

}  // namespace

void Simulation::check_sane(const State& state, State* copy) const {
  const System& system = problem_.system;
  std::string atoms;
  int count = 0;
  const char* worst = nullptr;
  // Written so that a NaN or infinite component fails too; no square root (this runs every step).
  auto bad = [](const Coords& c, int i, double limit) { return !(c.col(i).squaredNorm() <= limit * limit); };
  const int n = system.n_atoms();
  if (copy) {
    copy->q.resize(3, n);
    copy->v.resize(3, n);
    copy->step = state.step, copy->time = state.time;
  }
  // A parallel look first (copying as it reads); the serial pass below, which names the atoms,
  // runs only on a find.
  std::atomic<bool> any_bad = false;
  const WithinNormKernel within = simd::within_norm_kernel();
  for_atom_shares(n, [&](int first, int count) {
    const int c = 3 * first;
    // Every call runs: the copies must be whole.
    const bool q_ok = within(count, state.q.data() + c, kAbsurdPosition, copy ? copy->q.data() + c : nullptr);
    const bool v_ok = within(count, state.v.data() + c, kAbsurdVelocity, copy ? copy->v.data() + c : nullptr);
    const bool f_ok = within(count, state.f.data() + c, kAbsurdForce, nullptr);
    if (!(q_ok && v_ok && f_ok)) any_bad.store(true, std::memory_order_relaxed);
  });
  for (int i = 0; any_bad && i < n; ++i) {
    const char* what = bad(state.q, i, kAbsurdPosition)   ? "position"
                       : bad(state.v, i, kAbsurdVelocity) ? "velocity"
                       : bad(state.f, i, kAbsurdForce)    ? "force"
                                                          : nullptr;
    if (!what) continue;
    if (!worst) worst = what;
    if (++count <= 5) atoms += std::string(atoms.empty() ? "" : ", ") + system.atom_label(i) + " " + what;
  }
  if (count == 0 && (std::isfinite(state.potential) || !problem_.energies_due)) return;
  std::string message = state.step == start_step_ ? "the start state is unusable: "
                                                  : "the system blew up at step " + std::to_string(state.step) + ": ";
  if (count == 0)
    message += "the potential energy is not finite";
  else
    message += std::to_string(count) + " atom(s) with a non-finite or absurd position, velocity or force (|f| > " +
               "1e6 kJ/mol/nm, |v| > 1e3 nm/ps): " + atoms + (count > 5 ? ", ..." : "");
  message += "; try a smaller dt, or check the structure for overlapping atoms";
  throw BlowUpError(state.step, message);
}

void Simulation::write_checkpoint_now(const State& state, const RunInfo& info, const RunTotals& totals) {
  Checkpoint cp;
  cp.identity = checkpoints_.identity;
  cp.segments = checkpoints_.segments;
  cp.first_step = info.first_step;
  cp.last_step = info.last_step;
  cp.state = state;
  cp.integrator = integrator_.carried_state();
  cp.force_field = problem_.force_field.save();
  cp.totals.put("start_time", start_time_);
  cp.totals.put("wall_seconds", totals.wall_seconds);
  WorkCounters::fields([&](const char* name, auto counter) { cp.totals.put(name, static_cast<double>(totals.*counter)); });
  cp.totals.put("solver_iterations", static_cast<double>(totals.solver_iterations));
  for (auto& o : observers_) cp.observers.push_back(o->checkpoint(info));
  write_checkpoint(checkpoints_.file, cp);
}

RunTotals Simulation::run(State& state, long steps) {
  RunInfo info{problem_,       integrator_, state.step, state.step + steps, state.step, dt_,
               problem_.force_field.energy_names(), integrator_.diagnostic_names()};
  // The start's force evaluations count.
  work0_ = problem_.force_field.work();
  // A later run continues the same state: constrained and set up already.
  if (!initialized_) {
    const StartReport start = constrain_start(problem_, state);
    if (start_report_) start_report_(start);
    problem_.force_field.place_sites(state.q, state.v);
    integrator_.init(problem_, state);
    initialized_ = true;
    start_step_ = state.step;
  }
  check_sane(state);
  start_time_ = state.time;
  wall0_ = std::chrono::steady_clock::now();
  for (auto& o : observers_) o->begin(info);
  return loop(state, info, RunTotals{});
}

RunTotals Simulation::resume(const Checkpoint& cp, long last_step, State& state) {
  if (cp.observers.size() != observers_.size())
    throw std::logic_error("Simulation::resume: the checkpoint has " + std::to_string(cp.observers.size()) +
                           " observers, this simulation " + std::to_string(observers_.size()));
  RunInfo info{problem_,       integrator_, cp.first_step, last_step, cp.state.step, dt_,
               problem_.force_field.energy_names(), integrator_.diagnostic_names()};
  // init() sets the integrator up (its forces and start-up work are discarded); then the neighbour
  // lists, the State and the integrator's carried state are put back exactly as they were.
  State scratch = cp.state;
  integrator_.init(problem_, scratch);
  problem_.force_field.restore(cp.force_field);
  state = cp.state;
  integrator_.restore(problem_, state, cp.integrator);
  initialized_ = true;
  start_time_ = cp.totals.number("start_time");
  start_step_ = cp.first_step;
  // Only the work from here on counts on top of the checkpoint's totals.
  work0_ = problem_.force_field.work();
  wall0_ = std::chrono::steady_clock::now();
  RunTotals totals;
  totals.wall_seconds = cp.totals.number("wall_seconds");
  // A counter newer than the checkpoint starts at 0.
  WorkCounters::fields([&](const char* name, auto counter) {
    using Value = std::remove_reference_t<decltype(totals.*counter)>;
    totals.*counter = cp.totals.has(name) ? static_cast<Value>(cp.totals.number(name)) : Value(0);
  });
  totals.solver_iterations = static_cast<long>(cp.totals.number("solver_iterations"));
  for (std::size_t k = 0; k < observers_.size(); ++k) observers_[k]->resume(info, cp.observers[k]);
  return loop(state, info, totals);
}

RunTotals Simulation::loop(State& state, RunInfo& info, RunTotals base) {
  StepReport report;  // before the first step: no diagnostics (the energy file shows 0)
  auto notify = [&](bool force_all) {
    bool sampled = false;
    Sample s;
    for (auto& o : observers_) {
      const long every = o->every();
      if (force_all || (every > 0 && (state.step - info.first_step) % every == 0)) {
        if (!sampled && o->needs_sample()) s = sample(state, report), sampled = true;
        o->observe(info, state, s);
      }
    }
  };
  // Totals so far: the checkpoint's (if continued) plus this process's work.
  auto totals_now = [&] {
    RunTotals t = base;
    t.wall_seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0_).count();
    static_cast<WorkCounters&>(t) += problem_.force_field.work() - work0_;
    t.steps = state.step - info.first_step;
    return t;
  };
  // Energies only for the states that are sampled (GROMACS's nstcalcenergy): the force field skips
  // the energy work on the other steps. On-step velocities only where an observer reads them.
  // Both follow the schedule alone, so that a run continued from a checkpoint does what the
  // uninterrupted run did.
  auto due_at = [&](long step, bool (Observer::*wants)() const) {
    if (step == info.last_step) return true;
    for (auto& o : observers_)
      if (((*o).*wants)() && o->every() > 0 && (step - info.first_step) % o->every() == 0) return true;
    return false;
  };
  struct DueReset {  // the Problem outlives the run: energies and velocities everywhere are its default
    Problem& problem;
    ~DueReset() { problem.energies_due = problem.velocities_due = true; }
  } reset{problem_};
  if (info.start_step == info.first_step) notify(true);

  auto last_checkpoint = std::chrono::steady_clock::now();
  State last_good, next_good;  // the state before the step under way; the one after it while checked
  try {
    last_good.q = state.q, last_good.v = state.v;
    last_good.step = state.step, last_good.time = state.time;
    while (state.step < info.last_step) {
      problem_.energies_due = due_at(state.step + 1, &Observer::needs_sample);
      problem_.velocities_due = due_at(state.step + 1, &Observer::reads_velocities);
      report = integrator_.step(problem_, state);
      // Integrators move the atoms; the sites follow here, once, for output and checkpoints.
      problem_.force_field.place_sites(state.q, state.v);
      ++state.step;
      state.time = start_time_ + (state.step - info.first_step) * dt_;
      base.solver_iterations += report.iterations;
      check_sane(state, &next_good);
      std::swap(last_good, next_good);
      notify(state.step == info.last_step || report.finished);
      if (report.finished) break;  // a minimiser converged
      if (checkpoints_.file.empty()) continue;
      if (const int signal = stop_signal()) {
        RunTotals totals = totals_now();
        totals.stop_signal = signal;
        write_checkpoint_now(state, info, totals);
        for (auto& o : observers_) o->stop(info);
        return totals;
      }
      const auto now = std::chrono::steady_clock::now();
      const bool due = checkpoints_.every_steps > 0
                           ? (state.step - info.first_step) % checkpoints_.every_steps == 0
                           : std::chrono::duration<double>(now - last_checkpoint).count() >= checkpoints_.every_seconds;
      if (due && state.step < info.last_step) {
        write_checkpoint_now(state, info, totals_now());
        last_checkpoint = now;
      }
    }
  } catch (...) {
    // Best effort while failing already: the first error is the one to report.
    for (auto& o : observers_) try {
        o->fail(info, last_good);
      } catch (...) {
      }
    // A caller that goes on (the Python module) gets the last good state, not a half-made step's.
    if (last_good.q.cols() == state.q.cols()) {
      state.q = last_good.q, state.v = last_good.v;
      state.step = last_good.step, state.time = last_good.time;
    }
    throw;
  }
  RunTotals totals = totals_now();
  if (!checkpoints_.file.empty()) write_checkpoint_now(state, info, totals);
  for (auto& o : observers_) o->finish(info, state, totals);
  return totals;
}

}  // namespace vimd
