#include "integrators/rattle.hpp"

#include <algorithm>

#include "integrators/composition.hpp"
#include "integrators/coords_ops.hpp"
#include "integrators/verlet.hpp"

namespace vimd {

Rattle::Rattle(const IntegratorConfig& config)
    : ThermostattedIntegrator(config),
      dt_(config.dt),
      tolerance_(config.constraint_tolerance),
      max_iterations_(config.max_iterations) {
  check_step_config(config);
  const Composition composition = resolve_composition(config);
  name_ = composition.name == "none" ? "rattle" : "rattle (composition " + composition.name + ")";
  for (double gamma : composition.weights) sub_steps_.push_back(gamma * dt_);
}

void Rattle::init(Problem& problem, State& state) {
  check_start(problem, state);
  evaluate_forces(problem, state, forces_);
}

void Rattle::sub_step(Problem& problem, State& state, double h, bool energies, StepReport& report) {
  const Constraints& constraints = problem.constraints;
  const Eigen::VectorXd& inverse_mass = problem.inverse_mass;

  kick_drift(inverse_mass, state.f, 0.5 * h, h, state.v, state.q, &q_start_);
  if (!constraints.empty()) {
    double residual = 0;
    report.iterations += constraints.solve_positions(q_start_, state.q, inverse_mass, tolerance_, state.step + 1,
                                                     max_iterations_, nullptr, &residual);
    report.residual = std::max(report.residual, residual);
    // The half-step velocity that carries q_n to the constrained q_{n+1}. (Its rounding error,
    // ~1e-13 relative, is far below the constraint tolerance.)
    parallel_assign(state.v, (state.q - q_start_) / h);
  }
  evaluate_forces(problem, state, forces_, energies);
  kick(inverse_mass, state.f, 0.5 * h, state.v);
  constraints.project_velocities(state.q, state.v, inverse_mass);
}

StepReport Rattle::step(Problem& problem, State& state) {
  StepReport report;
  const std::size_t last = sub_steps_.size() - 1;
  for (std::size_t k = 0; k <= last; ++k)
    sub_step(problem, state, sub_steps_[k], k == last && problem.energies_due, report);
  thermostat_step(problem, state);
  return report;
}

}  // namespace vimd
