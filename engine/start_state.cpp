#include "engine/start_state.hpp"

#include <algorithm>
#include <cstdio>

#include "engine/errors.hpp"

namespace vimd {

namespace {
double max_column_norm(const Coords& d) { return d.cols() ? d.colwise().norm().maxCoeff() : 0.0; }
}  // namespace

StartReport constrain_start(const Problem& problem, State& state) {
  StartReport report;
  const Constraints& constraints = problem.constraints;
  if (constraints.empty()) return report;
  const Eigen::VectorXd& inverse_mass = problem.inverse_mass;
  double shortest = constraints.list().front().length;
  for (const Constraint& c : constraints.list()) shortest = std::min(shortest, c.length);

  // The closest point x solves x = y + W G(x)ᵀλ, g(x) = 0. SHAKE's position stage solves the same
  // with G taken at a reference point; iterating with the reference set to the last solution
  // converges linearly at a rate of order |x − y| / d (a few iterations for a 3-decimal .gro).
  const Coords y = state.q;
  Coords x = y, reference;
  constexpr int kMaxIterations = 50;
  double change = 0;
  for (;;) {
    ++report.iterations;
    reference = x;
    x = y;
    constraints.solve_positions(reference, x, inverse_mass, kStartTolerance, state.step);
    change = max_column_norm(x - reference);
    if (change <= 10 * kStartTolerance * shortest) break;
    if (report.iterations == kMaxIterations)
      throw ConvergenceError("start state (closest point on the constraints)", state.step, report.iterations, change,
                             "the positions read are too far from the constraint lengths");
  }
  if (x.cols() > 0) report.position_change = (x - y).colwise().norm().maxCoeff(&report.moved_atom);
  state.q = x;
  if (state.v.cols() == state.q.cols()) {
    const Coords v0 = state.v;
    constraints.project_velocities(state.q, state.v, inverse_mass);
    report.velocity_change = max_column_norm(state.v - v0);
  }
  return report;
}

std::string describe_start_change(const StartReport& report, const System& system) {
  char text[200];
  std::snprintf(text, sizeof text, "positions by up to %.3g nm", report.position_change);
  std::string out = text;
  if (report.moved_atom >= 0 && report.position_change > 0) {
    const int i = report.moved_atom;
    out += " (atom " + std::to_string(i + 1) + ", " + std::to_string(system.residue_numbers[i]) +
           system.residue_names[i] + " " + system.atom_names[i] + ")";
  }
  return out;
}

const char* start_state_description() {
  return "constrained once by the engine for every integrator: positions to the mass-weighted closest point on the "
         "constraints (relative deviation <= 1e-12), velocities by mass-weighted projection onto their tangent space";
}

}  // namespace vimd
