#pragma once
// One step of an integrator, never a run: the loop lives once, in Simulation.
#include <string>
#include <vector>

#include "engine/carried.hpp"
#include "engine/constraints.hpp"
#include "engine/force_field.hpp"
#include "engine/state.hpp"
#include "engine/system.hpp"

namespace vimd {

struct Problem {
  const System& system;
  ForceField& force_field;
  const Constraints& constraints;
  Eigen::VectorXd inverse_mass;  // per atom, 1/amu
  // Whether the state a step() ends in must carry its energies (State::potential, energy_terms):
  // the run loop clears it for steps nobody samples, so that the force field can skip the energy
  // work there (the state's energies are then NaN). Forces are always computed.
  bool energies_due = true;
  // Whether an observer sees the State::v a step() ends in. Where nobody does, an integrator may
  // leave in it any velocity from which its next step goes on to the same trajectory (RATTLE: v
  // before the velocity projection, whose part along the constraint gradients the next position
  // stage removes again), and a failed run's last_good state shows that velocity.
  bool velocities_due = true;
};

struct StepReport {
  int iterations = 0;               // solver iterations (constraint or variational)
  double residual = 0;              // final solver residual
  std::vector<double> diagnostics;  // aligned with Integrator::diagnostic_names()
  bool finished = false;            // nothing left to do (a minimiser converged): the run ends here
};

class Integrator {
 public:
  virtual ~Integrator() = default;
  virtual std::string name() const = 0;
  // Called once before the first step, on a start the engine has already constrained
  // (engine/start_state): computes forces and sets up internal state, never moves q or v.
  // Must leave state.f / potential / energy_terms consistent with state.q.
  virtual void init(Problem& problem, State& state) = 0;
  // Advances state by one step of dt; leaves forces and energies consistent with the new q.
  virtual StepReport step(Problem& problem, State& state) = 0;
  // Kinetic energy to report for state (leap-frog integrators average half steps).
  virtual double kinetic_energy(const Problem& problem, const State& state) const;
  // Energy a thermostat has put into the system so far (kJ/mol); total energy minus this is the
  // conserved quantity.
  virtual double thermostat_work() const { return 0; }
  // Extra per-step columns for the energy output (e.g. iterations, Noether momentum).
  virtual std::vector<std::string> diagnostic_names() const { return {}; }
  // Checkpoints: what the integrator carries from step to step besides the State (nothing for a
  // one-step method whose step depends on the State alone).
  virtual Carried carried_state() const { return {}; }
  // Continuing from a checkpoint: called after init(), with the State as it was checkpointed
  // (forces included) and what carried_state() returned then; the next step() must then do
  // exactly what it would have done in the uninterrupted run.
  virtual void restore(Problem& /*problem*/, const State& /*state*/, const Carried& /*carried*/) {}
};

// ½ Σ m v²
double kinetic_energy(const Eigen::VectorXd& mass, const Coords& v);

}  // namespace vimd
