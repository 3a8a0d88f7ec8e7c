#include "integrators/shake.hpp"

#include <utility>

#include "integrators/rattle.hpp"
#include "integrators/thermostat.hpp"
#include "integrators/verlet.hpp"

namespace vimd {

Shake::Shake(const IntegratorConfig& config)
    : dt_(config.dt), tolerance_(config.constraint_tolerance), max_iterations_(config.max_iterations) {
  check_step_config(config);
  refuse_thermostat(config,
                    "its leap-frog state holds half-step velocities, not the on-step kinetic energy v-rescale "
                    "scales; use type = \"rattle\" (the same trajectory with on-step velocities)");
}

void Shake::init(Problem& problem, State& state) {
  check_start(problem, state);
  evaluate_forces(problem, state, forces_);
  next_.valid = false;
}

bool Shake::half_step_matches(const State& state) const {
  const HalfStep& h = next_;
  return h.valid && h.key_step == state.step && h.key_q.cols() == state.q.cols() && h.key_q == state.q &&
         h.key_v == state.v && h.key_f == state.f;
}

void Shake::compute_half_step(const Problem& problem, const State& state, bool keep_key) const {
  const Constraints& constraints = problem.constraints;
  const Eigen::VectorXd& inverse_mass = problem.inverse_mass;
  HalfStep& h = next_;
  h.v = state.v;
  kick(inverse_mass, state.f, dt_, h.v);
  h.q = state.q + dt_ * h.v;
  h.iterations = 0;
  h.residual = 0;
  if (!constraints.empty()) {
    // Leaves h.v = (h.q − q)/dt (rounding error ~1e-13 relative, far below the tolerance).
    const StepVelocity half_step{h.v, dt_};
    h.iterations = constraints.solve_positions(state.q, h.q, inverse_mass, tolerance_, state.step + 1, max_iterations_,
                                               nullptr, &h.residual, &half_step);
  }
  h.valid = keep_key;
  if (keep_key) {
    h.key_q = state.q;
    h.key_v = state.v;
    h.key_f = state.f;
    h.key_step = state.step;
  }
}

StepReport Shake::step(Problem& problem, State& state) {
  if (!half_step_matches(state)) compute_half_step(problem, state, false);
  std::swap(state.q, next_.q);
  std::swap(state.v, next_.v);
  next_.valid = false;
  evaluate_forces(problem, state, forces_, problem.energies_due);
  StepReport report;
  report.iterations = next_.iterations;
  report.residual = next_.residual;
  return report;
}

double Shake::kinetic_energy(const Problem& problem, const State& state) const {
  if (!half_step_matches(state)) compute_half_step(problem, state, true);
  return 0.5 *
         (vimd::kinetic_energy(problem.system.mass, state.v) + vimd::kinetic_energy(problem.system.mass, next_.v));
}

}  // namespace vimd
