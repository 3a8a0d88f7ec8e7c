#pragma once
// The run's start belongs to the engine: the state read from the inputs is constrained once, the
// same way whatever the integrator, so frame 0 is identical for all of them (integrators only step).
//   positions:  the mass-weighted closest point on the constraint manifold,
//               q = y + M⁻¹G(q)ᵀλ with g(q) = 0 (y: the positions read);
//   velocities: the mass-weighted projection onto its tangent space, v ← v − M⁻¹Gᵀ(GM⁻¹Gᵀ)⁻¹Gv.
#include <string>

#include "engine/integrator.hpp"

namespace vimd {

// Relative constraint deviation the start is constrained to (well below any step's tolerance).
constexpr double kStartTolerance = 1e-12;

struct StartReport {
  int iterations = 0;             // outer fixed-point iterations for the closest point
  double position_change = 0;     // max |Δq| of any atom, nm
  int moved_atom = -1;            // the atom moved most (-1: none moved)
  double velocity_change = 0;     // max |Δv| of any atom, nm/ps
};

// Constrains state.q and (if present) state.v in place; ConvergenceError if the closest point
// cannot be found (a start far off the manifold).
StartReport constrain_start(const Problem& problem, State& state);

// One line for `vimd check`: how the start is constrained.
const char* start_state_description();

// How far the start moved, for `vimd check` and `vimd run`: "positions by up to 0.19 nm (atom 5,
// 2SOL HW1)".
std::string describe_start_change(const StartReport& report, const System& system);

}  // namespace vimd
