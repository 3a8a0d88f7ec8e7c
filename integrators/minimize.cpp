#include "integrators/minimize.hpp"

#include <cmath>
#include <utility>

#include "engine/errors.hpp"
#include "integrators/rattle.hpp"
#include "integrators/thermostat.hpp"
#include "integrators/verlet.hpp"

namespace vimd {

namespace {
// Below this largest displacement (nm) a trial move no longer changes the positions' doubles in a
// way the constraint solver and the energy can resolve: GROMACS's "converged to machine precision".
constexpr double kSmallestStep = 1e-12;
}  // namespace

SteepestDescent::SteepestDescent(const IntegratorConfig& config)
    : emtol_(config.emtol),
      step_size_(config.emstep),
      tolerance_(config.constraint_tolerance),
      max_iterations_(config.max_iterations) {
  if (!(emtol_ > 0)) throw SettingError("integrator", "emtol", "emtol must be positive (kJ/mol/nm)");
  if (!(step_size_ > 0)) throw SettingError("integrator", "emstep", "emstep must be positive (nm)");
  check_step_config(config);
  refuse_thermostat(config, "a minimisation has no temperature");
}

void SteepestDescent::constrained_force(const Problem& problem, const State& state) {
  constrained_f_ = state.f;
  problem.constraints.project_velocities(state.q, constrained_f_, ones_);
  Eigen::Index atom = 0;
  max_force_ = constrained_f_.cols() ? constrained_f_.colwise().norm().maxCoeff(&atom) : 0.0;
  max_force_atom_ = static_cast<int>(atom);
}

void SteepestDescent::init(Problem& problem, State& state) {
  check_start(problem, state);
  state.v.setZero();
  ones_ = Eigen::VectorXd::Ones(problem.system.n_atoms());
  evaluate_forces(problem, state, forces_);
  constrained_force(problem, state);
}

Carried SteepestDescent::carried_state() const {
  Carried c;
  c.put("step_size", step_size_);
  return c;
}

void SteepestDescent::restore(Problem& problem, const State& state, const Carried& carried) {
  step_size_ = carried.number("step_size");
  constrained_force(problem, state);
}

StepReport SteepestDescent::report() const {
  StepReport r;
  r.diagnostics = {max_force_, static_cast<double>(max_force_atom_ + 1), step_size_};
  r.finished = max_force_ < emtol_ || step_size_ < kSmallestStep;
  return r;
}

StepReport SteepestDescent::step(Problem& problem, State& state) {
  if (max_force_ < emtol_ || step_size_ < kSmallestStep) return report();
  trial_.q = state.q + (step_size_ / max_force_) * constrained_f_;
  int iterations = 0;
  double residual = 0;
  bool on_manifold = true;
  if (!problem.constraints.empty()) {
    try {
      iterations = problem.constraints.solve_positions(state.q, trial_.q, ones_, tolerance_, state.step + 1,
                                                       max_iterations_, nullptr, &residual);
    } catch (const ConvergenceError& e) {
      // A move too large for the constraints to follow (molecules turned too far): reject it
      // like an uphill one; the smaller step that follows is solvable.
      on_manifold = false;
      iterations = e.iterations();
      residual = e.residual();
    }
  }
  if (on_manifold) evaluate_forces(problem, trial_, forces_);
  if (on_manifold && trial_.potential < state.potential) {
    std::swap(state.q, trial_.q);
    std::swap(state.f, trial_.f);
    state.potential = trial_.potential;
    std::swap(state.energy_terms, trial_.energy_terms);
    constrained_force(problem, state);
    step_size_ *= 1.2;
  } else {
    step_size_ *= 0.2;
  }
  StepReport r = report();
  r.iterations = iterations;
  r.residual = residual;
  return r;
}

}  // namespace vimd
