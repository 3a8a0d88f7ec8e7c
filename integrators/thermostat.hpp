#pragma once
// The stochastic velocity-rescaling thermostat (Bussi, Donadio, Parrinello, J. Chem. Phys. 126,
// 014101 (2007)), as GROMACS's v-rescale: after each step the on-step velocities are scaled by
// one factor α so that the kinetic energy K follows
//   dK = (K̄ − K) dt/τ + 2 √(K K̄ / N_f) dW/√τ,   K̄ = ½ N_f k_B T,
// integrated exactly over dt. The canonical kinetic-energy distribution is its stationary law.
// A uniform scaling keeps the velocity constraints (G v = 0) and zero total momentum. The energy
// the bath puts in, Σ (K_after − K_before), is kept, so total energy minus it is conserved up to
// the integrator's own error.
#include <array>
#include <cstdint>
#include <optional>
#include <string>

#include "engine/carried.hpp"
#include "integrators/settings.hpp"
#include "engine/integrator.hpp"
#include "engine/types.hpp"

namespace vimd {

// Everything the thermostat carries from step to step (what a checkpoint must save).
struct VRescaleState {
  std::array<std::uint64_t, 4> rng{};  // xoshiro256** state
  double work = 0;                     // kJ/mol: Σ (K_after − K_before) so far
};

// A small explicit random stream (xoshiro256**, Blackman & Vigna) with the deviates the
// thermostat needs; no hidden caches, so VRescaleState::rng is its whole state.
class RandomStream {
 public:
  explicit RandomStream(std::array<std::uint64_t, 4>& state) : s_(state) {}
  static std::array<std::uint64_t, 4> seeded(std::uint64_t seed);  // splitmix64 expansion
  double uniform();                  // in (0, 1)
  double normal();                   // standard normal (Box–Muller, one deviate per call)
  double gamma(double shape);        // Gamma(shape, 1) (Marsaglia–Tsang)
  double chi_squared(int n);         // Σ of n squared standard normals

 private:
  std::array<std::uint64_t, 4>& s_;
};

class VRescaleThermostat {
 public:
  // temperature in K, tau_t and dt in ps (tau_t = 0: the kinetic energy is redrawn every step).
  VRescaleThermostat(double temperature, double tau_t, double dt, std::uint64_t seed);
  // Rescales v towards the canonical distribution for `dof` degrees of freedom.
  void apply(const Eigen::VectorXd& mass, int dof, Coords& v);
  // The new kinetic energy drawn for current kinetic energy `kinetic` (kJ/mol).
  double resample(double kinetic, int dof);
  double work() const { return state_.work; }
  const VRescaleState& state() const { return state_; }
  void set_state(const VRescaleState& state) { state_ = state; }
  // For a checkpoint: the state as exact doubles (each random word as two 32-bit halves), so a
  // continued run draws the same numbers as an uninterrupted one.
  void save(Carried& carried) const;
  void load(const Carried& carried);

 private:
  double temperature_, decay_;  // decay = exp(−dt/τ)
  VRescaleState state_;
};

// The thermostat [integrator] asks for (none when thermostat = "none"); for integrators that
// step on-step velocities (velocity Verlet, RATTLE).
std::optional<VRescaleThermostat> make_thermostat(const IntegratorConfig& config);
// For integrators that cannot carry a thermostat: InputError naming the integrator and `why`.
void refuse_thermostat(const IntegratorConfig& config, const std::string& why);

// An integrator of on-step velocities that may carry the thermostat [integrator] asks for: it
// calls thermostat_step at the end of each step; the thermostat's work and random stream are
// all a checkpoint needs besides the State.
class ThermostattedIntegrator : public Integrator {
 public:
  explicit ThermostattedIntegrator(const IntegratorConfig& config) : thermostat_(make_thermostat(config)) {}
  double thermostat_work() const override { return thermostat_ ? thermostat_->work() : 0.0; }
  Carried carried_state() const override {
    Carried c;
    if (thermostat_) thermostat_->save(c);
    return c;
  }
  void restore(Problem&, const State&, const Carried& carried) override {
    if (thermostat_) thermostat_->load(carried);
  }

 protected:
  bool has_thermostat() const { return thermostat_.has_value(); }
  // Rescales v_{n+1} (no-op without a thermostat).
  void thermostat_step(const Problem& problem, State& state) {
    if (thermostat_) thermostat_->apply(problem.system.mass, problem.system.degrees_of_freedom(), state.v);
  }

 private:
  std::optional<VRescaleThermostat> thermostat_;
};

}  // namespace vimd
