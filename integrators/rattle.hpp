#pragma once
// RATTLE (Andersen 1983): velocity Verlet with a position constraint stage (Newton on the
// multipliers along G(q_n)ᵀ) and a velocity projection onto the tangent space at q_{n+1}.
// State::v holds the on-step velocity v_n.

#include "engine/config.hpp"
#include "engine/integrator.hpp"
#include "integrators/thermostat.hpp"

namespace vimd {

class Rattle : public ThermostattedIntegrator {
 public:
  explicit Rattle(const IntegratorConfig& config);
  std::string name() const override { return "rattle"; }
  void init(Problem& problem, State& state) override;
  // iterations: constraint (Newton) iterations of the position stage; residual: the final
  // maximum relative bond-length deviation.
  // With thermostat = "v-rescale", v_{n+1} is rescaled at the end of the step.
  StepReport step(Problem& problem, State& state) override;

 private:
  double dt_, tolerance_;
  int max_iterations_;
  Forces forces_;
  Coords q_start_;
};

}  // namespace vimd
