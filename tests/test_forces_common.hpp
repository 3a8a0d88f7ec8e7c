#pragma once
// What the force-term tests (tests/test_forces_*.cpp, one file per term) share besides the test
// systems (test_ff_systems.hpp) and the derivative checks (derivative_checks.hpp): GROMACS's
// potential switch, written here independently from the reference manual ("Modified non-bonded
// interactions"), for the sums the pair forms' energies are checked against.
#include "derivative_checks.hpp"
#include "test_ff_systems.hpp"

namespace vimd::testing {

inline double manual_switch(double r, double r1, double rc) {
  if (r < r1) return 1;
  const double t = (r - r1) / (rc - r1);
  return 1 - 10 * t * t * t + 15 * t * t * t * t - 6 * t * t * t * t * t;
}

}  // namespace vimd::testing
