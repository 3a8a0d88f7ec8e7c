// The 1–4 pair term: LJ and Coulomb energies against a direct sum, derivatives against finite
// differences, and no Coulomb without electrostatics.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "forcefields/pairs_14.hpp"
#include "test_forces_common.hpp"

namespace vimd {
namespace {

using testing::evaluate;
using testing::expect_derivatives_match;

TEST(Pair14Term, EnergiesForcesAndHessianVector) {
  auto [system, q] = testing::chain_system(12, 6, Vec3(1.5, 1.6, 1.7), 32);
  ForceFieldConfig config;
  config.epsilon_r = 2.0;
  Pair14Term term(system.pairs14, system.box, config);
  EXPECT_EQ(term.energy_names(), (std::vector<std::string>{"lj14", "coulomb14"}));
  double lj = 0, coulomb = 0;
  for (const Pair14& p : system.pairs14) {
    const double r = system.box.minimum_image(q.col(p.i) - q.col(p.j)).norm();
    lj += p.c12 / std::pow(r, 12) - p.c6 / std::pow(r, 6);
    coulomb += kCoulomb / 2.0 * p.qq / r;  // f/ε_r, ε_r = 2; epsilon_rf plays no part
  }
  const auto result = evaluate(term, q);
  EXPECT_NEAR(result.energies[0], lj, 1e-12 * std::abs(lj));
  EXPECT_NEAR(result.energies[1], coulomb, 1e-12 * std::abs(coulomb));
  expect_derivatives_match(term, q, "1-4 pairs");
  config.coulomb = "none";  // no electrostatics at all
  Pair14Term uncharged(system.pairs14, system.box, config);
  const auto without = evaluate(uncharged, q);
  EXPECT_EQ(without.energies[1], 0.0);
  EXPECT_EQ(without.energies[0], result.energies[0]);
}

}  // namespace
}  // namespace vimd
