#pragma once
// RATTLE (Andersen 1983): velocity Verlet with a position constraint stage (Newton on the
// multipliers along G(q_n)ᵀ) and a velocity projection onto the tangent space at q_{n+1}.
// State::v holds the on-step velocity v_n where Problem::velocities_due (see sub_step).
//
// With [integrator] composition, a step is a symmetric composition of RATTLE sub-steps of
// γ_k dt (integrators/composition.hpp): each sub-step ends with the force the next one starts
// from, so a step of s sub-steps costs s force evaluations.

#include <vector>

#include "integrators/settings.hpp"
#include "engine/integrator.hpp"
#include "integrators/thermostat.hpp"

namespace vimd {

class Rattle : public ThermostattedIntegrator {
 public:
  explicit Rattle(const IntegratorConfig& config);
  // "rattle", or with a composition "rattle (composition yoshida4)"
  std::string name() const override { return name_; }
  void init(Problem& problem, State& state) override;
  // iterations: constraint (Newton) iterations of the position stages, summed over the sub-steps;
  // residual: the largest final maximum relative bond-length deviation of a sub-step.
  // With thermostat = "v-rescale", v_{n+1} is rescaled once, at the end of the whole step.
  StepReport step(Problem& problem, State& state) override;
  Carried carried_state() const override;
  void restore(Problem& problem, const State& state, const Carried& carried) override;

 private:
  // One RATTLE step of length h (negative in some compositions) up to, not including, the velocity
  // projection; energies as Problem::energies_due.
  //
  // Without the projection v_{n+1} keeps a part along the constraint gradients at q_{n+1}, which
  // the next position stage, a solve along the same gradients, removes again: positions and later
  // projected velocities are the same (to the constraint tolerance). So only velocities someone
  // sees are projected (Problem::velocities_due), and only at the end of the whole step.
  void sub_step(Problem& problem, State& state, double h, bool energies, StepReport& report);

  // Whether state.v still holds what the last step left there (projected_); virtual sites, whose
  // velocities follow the atoms' after each step, aside.
  bool velocities_untouched(const Problem& problem, const State& state) const;

  // A step whose velocities are seen projects them for the observers, but the next step goes on
  // from v before that projection, as if nobody had looked: whether a state is observed (an
  // energy step, the end of a chunk of steps) changes no trajectory, not even by a rounding. Unless
  // State::v has changed since: velocities set from outside are taken as they are.
  Coords unprojected_, projected_;
  bool projected_last_ = false;  // the last step left projected_ in State::v

  std::string name_;
  double dt_, tolerance_;
  int max_iterations_;
  std::vector<double> sub_steps_;  // h_k = γ_k dt; {dt} without a composition
  Forces forces_;
  Coords q_start_;
};

}  // namespace vimd
