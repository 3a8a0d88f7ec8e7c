#pragma once
// RATTLE (Andersen 1983): velocity Verlet with a position constraint stage (Newton on the
// multipliers along G(q_n)ᵀ) and a velocity projection onto the tangent space at q_{n+1}.
// State::v holds the on-step velocity v_n.
//
// With [integrator] composition, a step is a symmetric composition of RATTLE sub-steps of
// γ_k dt (integrators/composition.hpp): each sub-step ends with the force the next one starts
// from, so a step of s sub-steps costs s force evaluations.

#include <vector>

#include "engine/config.hpp"
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

 private:
  // One RATTLE step of length h (negative in some compositions); energies as Problem::energies_due.
  void sub_step(Problem& problem, State& state, double h, bool energies, StepReport& report);

  std::string name_;
  double dt_, tolerance_;
  int max_iterations_;
  std::vector<double> sub_steps_;  // h_k = γ_k dt; {dt} without a composition
  Forces forces_;
  Coords q_start_;
};

}  // namespace vimd
