// The harmonic bond term: its energy against a direct sum, its derivatives against finite differences.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "forcefields/harmonic_bond.hpp"
#include "test_forces_common.hpp"

namespace vimd {
namespace {

using testing::evaluate;
using testing::expect_derivatives_match;

TEST(HarmonicBondTerm, DerivativesMatchFiniteDifferences) {
  auto [system, q] = testing::water_like_system(6, Vec3(2.0, 2.0, 2.0), 21);
  // Molecules straddling the box edge exercise the minimum image.
  q.row(0).array() += 1.95;
  HarmonicBondTerm term(system.bonds, system.box);
  EXPECT_EQ(term.energy_names(), std::vector<std::string>{"bonds"});
  expect_derivatives_match(term, q, "bonds");
  double expected = 0;
  for (const Bond& b : system.bonds) {
    const double r = system.box.minimum_image(q.col(b.i) - q.col(b.j)).norm();
    expected += 0.5 * b.k * (r - b.length) * (r - b.length);
  }
  EXPECT_NEAR(evaluate(term, q).energy, expected, 1e-12 * expected);
}

}  // namespace
}  // namespace vimd
