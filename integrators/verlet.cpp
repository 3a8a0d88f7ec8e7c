#include "integrators/verlet.hpp"

#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <string>
#include <utility>

#include "simd/atom_kernels.hpp"
#include "engine/errors.hpp"
#include "integrators/coords_ops.hpp"

namespace vimd {

void kick(const Eigen::VectorXd& inverse_mass, const Coords& f, double h, Coords& v) {
  const KickKernel kernel = simd::kick_kernel();
  for_atom_shares(static_cast<int>(v.cols()), [&](int first, int count) {
    kernel(count, inverse_mass.data() + first, h, f.data() + 3 * first, v.data() + 3 * first);
  });
}

void kick_drift(const Eigen::VectorXd& inverse_mass, const Coords& f, double h_kick, double h_drift, Coords& v,
                Coords& q, Coords* q_before) {
  if (q_before) q_before->resize(3, v.cols());
  const KickDriftKernel kernel = simd::kick_drift_kernel();
  for_atom_shares(static_cast<int>(v.cols()), [&](int first, int count) {
    kernel(count, inverse_mass.data() + first, h_kick, h_drift, f.data() + 3 * first, v.data() + 3 * first,
           q.data() + 3 * first, q_before ? q_before->data() + 3 * first : nullptr);
  });
}

void evaluate_forces(Problem& problem, State& state, Forces& scratch, bool energies) {
  if (energies)
    problem.force_field.compute(state.q, scratch);
  else
    problem.force_field.compute_forces(state.q, scratch);
  std::swap(state.f, scratch.f);  // the old force array becomes next call's scratch
  state.potential = scratch.potential;
  state.energy_terms = scratch.terms;
}

void check_start(const Problem& problem, State& state) {
  const int n = problem.system.n_atoms();
  if (state.q.cols() != n || problem.inverse_mass.size() != n)
    throw std::invalid_argument("integrator: the state has " + std::to_string(state.q.cols()) + " atoms and " +
                                std::to_string(problem.inverse_mass.size()) + " inverse masses, the system " +
                                std::to_string(n) + " atoms");
  if (state.v.cols() == 0) state.v = Coords::Zero(3, n);
  if (state.v.cols() != n)
    throw std::invalid_argument("integrator: the state has " + std::to_string(state.v.cols()) + " velocities for " +
                                std::to_string(n) + " atoms");
}

namespace {
std::string number(double x) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", x);
  return buf;
}
}  // namespace

void check_step_config(const IntegratorConfig& config) {
  if (!(config.dt > 0) || !std::isfinite(config.dt))
    throw SettingError("integrator", "dt", "dt must be a positive time step in ps, got " + number(config.dt));
  if (!(config.constraint_tolerance > 0 && config.constraint_tolerance < 1))
    throw SettingError(
        "integrator", "constraint_tolerance",
        "constraint_tolerance is relative and must lie in (0, 1), got " + number(config.constraint_tolerance));
  if (config.max_iterations < 1)
    throw SettingError("integrator", "max_iterations",
                       "max_iterations must be at least 1, got " + std::to_string(config.max_iterations));
}

VelocityVerlet::VelocityVerlet(const IntegratorConfig& config) : ThermostattedIntegrator(config), dt_(config.dt) {
  check_step_config(config);
}

void VelocityVerlet::init(Problem& problem, State& state) {
  if (!problem.constraints.empty())
    throw SettingError("integrator", "type",
                       "type = \"verlet\" cannot keep the " + std::to_string(problem.constraints.size()) +
                           " constraints of this system; use type = \"rattle\" (velocity Verlet with constraints)");
  check_start(problem, state);
  evaluate_forces(problem, state, forces_);
}

StepReport VelocityVerlet::step(Problem& problem, State& state) {
  kick_drift(problem.inverse_mass, state.f, 0.5 * dt_, dt_, state.v, state.q);
  evaluate_forces(problem, state, forces_, problem.energies_due);
  kick(problem.inverse_mass, state.f, 0.5 * dt_, state.v);
  thermostat_step(problem, state);
  return {};
}

}  // namespace vimd
