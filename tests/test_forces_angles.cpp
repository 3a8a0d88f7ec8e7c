// The harmonic angle term: its energy against a direct sum, its derivatives against finite
// differences, also near a straight angle.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "forcefields/harmonic_angle.hpp"
#include "test_forces_common.hpp"

namespace vimd {
namespace {

using testing::evaluate;
using testing::expect_derivatives_match;

TEST(HarmonicAngleTerm, DerivativesMatchFiniteDifferences) {
  auto [system, q] = testing::water_like_system(6, Vec3(2.0, 2.0, 2.0), 22);
  q.row(1).array() += 1.95;
  HarmonicAngleTerm term(system.angles, system.box);
  EXPECT_EQ(term.energy_names(), std::vector<std::string>{"angles"});
  expect_derivatives_match(term, q, "angles");
  double expected = 0;
  for (const Angle& a : system.angles) {
    const Vec3 u = system.box.minimum_image(q.col(a.i) - q.col(a.j)),
               v = system.box.minimum_image(q.col(a.k) - q.col(a.j));
    const double theta = std::acos(u.dot(v) / (u.norm() * v.norm()));
    expected += 0.5 * a.force_constant * (theta - a.theta0) * (theta - a.theta0);
  }
  EXPECT_NEAR(evaluate(term, q).energy, expected, 1e-10 * expected);
}

TEST(HarmonicAngleTerm, NearlyStraightAngle) {
  System system;
  system.box.length = Vec3::Zero();
  Coords q(3, 3);
  q << 0.1, 0.0, -0.1, 0.0, 0.0, 0.003, 0.0, 0.0, 0.0;
  HarmonicAngleTerm term({{0, 1, 2, 2.0, 400.0}}, system.box);
  expect_derivatives_match(term, q, "angle near 180 degrees");
}

}  // namespace
}  // namespace vimd
