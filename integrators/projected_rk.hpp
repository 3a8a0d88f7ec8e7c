#pragma once
// Type "rk": the standard layer alone, Φ_h from the tableau, then positions projected onto the
// constraints (P: docs/variational-integrator.md, "Projection onto the constraint manifold") and
// velocities M-orthogonally onto the tangent space. Order p, but
// neither symplectic nor momentum-conserving in the discrete sense: the baseline the variational
// integrator is compared with.
#include <memory>
#include <string>

#include "integrators/settings.hpp"
#include "engine/integrator.hpp"
#include "integrators/tableau.hpp"

namespace vimd {

class ProjectedRungeKutta : public Integrator {
 public:
  ProjectedRungeKutta(ButcherTableau tableau, double dt, std::string projection);
  // From [integrator] (type = "rk"): method, dt, projection; InputError on bad settings.
  explicit ProjectedRungeKutta(const IntegratorConfig& config);
  ~ProjectedRungeKutta() override;

  std::string name() const override { return "rk"; }
  void init(Problem& problem, State& state) override;
  // StepReport: iterations and residual of the position projection.
  StepReport step(Problem& problem, State& state) override;
  // Carries nothing but the forces at the current positions, which the State holds.
  void restore(Problem& problem, const State& state, const Carried& carried) override;

 private:
  struct Work;
  ButcherTableau tableau_;
  double dt_;
  std::string projection_;
  std::unique_ptr<Work> work_;
};

}  // namespace vimd
