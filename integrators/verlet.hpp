#pragma once
// Velocity Verlet for unconstrained systems, plus the pieces the constrained integrators
// (SHAKE, RATTLE) share with it: the half kick, the force update and the config checks.

#include "integrators/settings.hpp"
#include "engine/integrator.hpp"
#include "integrators/thermostat.hpp"

namespace vimd {

// v += h M⁻¹ f
void kick(const Eigen::VectorXd& inverse_mass, const Coords& f, double h, Coords& v);
// kick, then q ← q + h_drift v (the old q to q_before if given), in one pass over the atoms.
void kick_drift(const Eigen::VectorXd& inverse_mass, const Coords& f, double h_kick, double h_drift, Coords& v,
                Coords& q, Coords* q_before = nullptr);
// state.f, state.potential, state.energy_terms ← the force field at state.q (the energies NaN
// without `energies`). `scratch` is the caller's reusable buffer, so steady-state steps do not allocate.
void evaluate_forces(Problem& problem, State& state, Forces& scratch, bool energies = true);
// Checks that state and problem sizes agree; a state without velocities starts at rest.
void check_start(const Problem& problem, State& state);
// InputError for a time step, tolerance or iteration limit no integrator can use.
void check_step_config(const IntegratorConfig& config);

class VelocityVerlet : public ThermostattedIntegrator {
 public:
  explicit VelocityVerlet(const IntegratorConfig& config);
  std::string name() const override { return "verlet"; }
  // Refuses constrained systems (use RATTLE); computes the starting forces.
  void init(Problem& problem, State& state) override;
  // With thermostat = "v-rescale", v_{n+1} is rescaled at the end of the step.
  StepReport step(Problem& problem, State& state) override;

 private:
  double dt_;
  Forces forces_;
};

}  // namespace vimd
