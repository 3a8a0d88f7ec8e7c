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
  projected_last_ = false;
}

void Rattle::sub_step(Problem& problem, State& state, double h, bool energies, StepReport& report) {
  const Constraints& constraints = problem.constraints;
  const Eigen::VectorXd& inverse_mass = problem.inverse_mass;

  kick_drift(inverse_mass, state.f, 0.5 * h, h, state.v, state.q, &q_start_);
  if (!constraints.empty()) {
    double residual = 0;
    // Leaves the half-step velocity that carries q_n to the constrained q_{n+1}. (Its rounding
    // error, ~1e-13 relative, is far below the constraint tolerance.)
    const StepVelocity half_step{state.v, h};
    report.iterations += constraints.solve_positions(q_start_, state.q, inverse_mass, tolerance_, state.step + 1,
                                                     max_iterations_, nullptr, &residual, &half_step);
    report.residual = std::max(report.residual, residual);
  }
  evaluate_forces(problem, state, forces_, energies);
  kick(inverse_mass, state.f, 0.5 * h, state.v);
}

StepReport Rattle::step(Problem& problem, State& state) {
  StepReport report;
  if (velocities_untouched(problem, state)) state.v.swap(unprojected_);
  projected_last_ = false;
  const std::size_t last = sub_steps_.size() - 1;
  for (std::size_t k = 0; k <= last; ++k)
    sub_step(problem, state, sub_steps_[k], k == last && problem.energies_due, report);
  const Constraints& constraints = problem.constraints;
  if (has_thermostat()) {
    // The thermostat scales on-step velocities, and the dynamics go on from the scaled ones.
    constraints.project_velocities(state.q, state.v, problem.inverse_mass);
  } else if (problem.velocities_due && !constraints.empty()) {
    unprojected_ = state.v;
    constraints.project_velocities(state.q, state.v, problem.inverse_mass);
    projected_ = state.v;
    projected_last_ = true;
  }
  thermostat_step(problem, state);
  return report;
}

bool Rattle::velocities_untouched(const Problem& problem, const State& state) const {
  if (!projected_last_ || state.v.cols() != projected_.cols()) return false;
  for (Eigen::Index i = 0; i < state.v.cols(); ++i)
    if (problem.inverse_mass[i] > 0 && state.v.col(i) != projected_.col(i)) return false;
  return true;
}

Carried Rattle::carried_state() const {
  Carried c = ThermostattedIntegrator::carried_state();
  if (projected_last_) c.put("rattle_unprojected_velocities", unprojected_);
  return c;
}

void Rattle::restore(Problem& problem, const State& state, const Carried& carried) {
  ThermostattedIntegrator::restore(problem, state, carried);
  projected_last_ = carried.has("rattle_unprojected_velocities");
  if (!projected_last_) return;
  unprojected_ = carried.coords("rattle_unprojected_velocities");
  if (unprojected_.cols() != state.v.cols())
    throw std::runtime_error("checkpoint: entry \"rattle_unprojected_velocities\" has the wrong size");
  projected_ = state.v;
}

}  // namespace vimd
