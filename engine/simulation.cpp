#include "engine/simulation.hpp"

#include <cmath>

#include "engine/errors.hpp"

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

RunTotals Simulation::run(State& state, long steps) {
  const std::vector<std::string> diagnostic_names = integrator_.diagnostic_names();
  RunInfo info{problem_, integrator_, state.step, state.step + steps, dt_,
               problem_.force_field.energy_names(), diagnostic_names};

  const long evaluations0 = problem_.force_field.force_evaluations();
  const long hessians0 = problem_.force_field.hessian_evaluations();
  const long rebuilds0 = problem_.force_field.neighbor_rebuilds();
  if (!initialized_) integrator_.init(problem_, state);
  initialized_ = true;
  const auto start = std::chrono::steady_clock::now();

  for (auto& o : observers_) o->begin(info);
  StepReport report;
  report.diagnostics.assign(diagnostic_names.size(), std::nan(""));
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
  notify(true);

  RunTotals totals;
  const double t0 = state.time;
  for (long n = 0; n < steps; ++n) {
    report = integrator_.step(problem_, state);
    ++state.step;
    ++totals.steps;
    state.time = t0 + (n + 1) * dt_;
    totals.solver_iterations += report.iterations;
    if (!std::isfinite(state.potential))
      throw ConvergenceError(integrator_.name(), state.step, report.iterations, report.residual,
                             "the potential energy is not finite (the system blew up; try a smaller dt)");
    notify(n + 1 == steps || report.finished);
    if (report.finished) break;
  }

  totals.wall_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  totals.force_evaluations = problem_.force_field.force_evaluations() - evaluations0;
  totals.hessian_evaluations = problem_.force_field.hessian_evaluations() - hessians0;
  totals.neighbor_rebuilds = problem_.force_field.neighbor_rebuilds() - rebuilds0;
  for (auto& o : observers_) o->finish(info, state, totals);
  return totals;
}

}  // namespace vimd
