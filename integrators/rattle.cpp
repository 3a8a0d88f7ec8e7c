#include "integrators/rattle.hpp"

#include "integrators/coords_ops.hpp"
#include "integrators/verlet.hpp"

namespace vimd {

Rattle::Rattle(const IntegratorConfig& config)
    : ThermostattedIntegrator(config),
      dt_(config.dt),
      tolerance_(config.constraint_tolerance),
      max_iterations_(config.max_iterations) {
  check_step_config(config);
}

void Rattle::init(Problem& problem, State& state) {
  check_start(problem, state);
  evaluate_forces(problem, state, forces_);
}

StepReport Rattle::step(Problem& problem, State& state) {
  const Constraints& constraints = problem.constraints;
  const Eigen::VectorXd& inverse_mass = problem.inverse_mass;
  StepReport report;

  kick(inverse_mass, state.f, 0.5 * dt_, state.v);
  q_start_.resize(3, state.q.cols());
  for_each_atom(static_cast<int>(state.q.cols()), [&](int i) {
    q_start_.col(i) = state.q.col(i);
    state.q.col(i) += dt_ * state.v.col(i);
  });
  if (!constraints.empty()) {
    report.iterations = constraints.solve_positions(q_start_, state.q, inverse_mass, tolerance_, state.step + 1,
                                                    max_iterations_, nullptr, &report.residual);
    // The half-step velocity that carries q_n to the constrained q_{n+1}. (Its rounding error,
    // ~1e-13 relative, is far below the constraint tolerance.)
    parallel_assign(state.v, (state.q - q_start_) / dt_);
  }
  evaluate_forces(problem, state, forces_, problem.energies_due);
  kick(inverse_mass, state.f, 0.5 * dt_, state.v);
  constraints.project_velocities(state.q, state.v, inverse_mass);
  thermostat_step(problem, state);
  return report;
}

}  // namespace vimd
