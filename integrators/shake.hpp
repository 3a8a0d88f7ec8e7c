#pragma once
// SHAKE (Ryckaert, Ciccotti, Berendsen 1977) in leap-frog form, as GROMACS's md integrator:
//   v_{n+1/2} = v_{n−1/2} + dt M⁻¹ f_n,  q̃ = q_n + dt v_{n+1/2},
//   q_{n+1} = q̃ + M⁻¹ G(q_n)ᵀ λ with g(q_{n+1}) = 0,  v_{n+1/2} = (q_{n+1} − q_n)/dt.
// State convention (GROMACS's): at step n, state.q = q_n, state.f = f(q_n) and state.v = v_{n−1/2};
// starting velocities are read as v_{−1/2}. The reported kinetic energy at step n is the average
// of the half-step kinetic energies at n−½ and n+½, so it needs v_{n+1/2}: the integrator
// computes that half step once and keeps it for the next step().
#include "integrators/settings.hpp"
#include "engine/integrator.hpp"

namespace vimd {

class Shake : public Integrator {
 public:
  explicit Shake(const IntegratorConfig& config);
  std::string name() const override { return "shake"; }
  // Constrains q_0 and projects v_{−1/2} onto the tangent space at q_0, then computes f_0.
  void init(Problem& problem, State& state) override;
  // iterations / residual: those of the position constraint solve for q_{n+1}.
  StepReport step(Problem& problem, State& state) override;
  // ½ (K(v_{n−1/2}) + K(v_{n+1/2}))
  double kinetic_energy(const Problem& problem, const State& state) const override;

 private:
  // q_{n+1} and v_{n+1/2} computed from a state (q_n, v_{n−1/2}, f_n), with a copy of that
  // state as the key, so a state changed in between (e.g. by a thermostat) is never stepped
  // with a stale half step.
  struct HalfStep {
    Coords q, v;
    Coords key_q, key_v, key_f;
    long key_step = 0;
    bool valid = false;
    int iterations = 0;
    double residual = 0;
  };
  bool half_step_matches(const State& state) const;
  void compute_half_step(const Problem& problem, const State& state, bool keep_key) const;

  double dt_, tolerance_;
  int max_iterations_;
  Forces forces_;
  mutable HalfStep next_;
};

}  // namespace vimd
