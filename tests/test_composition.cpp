// RATTLE's compositions as data: the built-in weight sets (stages, symmetry, sum, the order they
// claim and no more), the order check against the closed-form conditions, the errors a user's
// weights meet, and the run file offering exactly the built-ins.
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <string>

#include "app/run_schema.hpp"
#include "engine/config_schema.hpp"
#include "engine/errors.hpp"
#include "integrators/composition.hpp"

namespace vimd {
namespace {

double power_sum(const std::vector<double>& weights, int power) {
  double sum = 0;
  for (double w : weights) sum += std::pow(w, power);
  return sum;
}

TEST(Composition, BuiltinsHaveTheirStagesSymmetryAndExactOrder) {
  const std::map<std::string, std::pair<int, int>> expected = {
      {"yoshida4", {3, 4}}, {"suzuki4", {5, 4}}, {"kahan-li6", {9, 6}}, {"kahan-li8", {17, 8}}};
  ASSERT_EQ(composition_names().size(), expected.size());
  for (const std::string& name : composition_names()) {
    SCOPED_TRACE(name);
    const Composition& c = builtin_composition(name);
    ASSERT_EQ(expected.count(name), 1u);
    EXPECT_EQ(c.stages(), expected.at(name).first);
    EXPECT_EQ(c.order, expected.at(name).second);
    for (int k = 0; k < c.stages(); ++k) EXPECT_EQ(c.weights[k], c.weights[c.stages() - 1 - k]);
    EXPECT_NEAR(power_sum(c.weights, 1), 1.0, 4e-16);
    // The claimed order and not the next: the check sees the conditions fail above it.
    EXPECT_EQ(satisfied_composition_order(c.weights), c.order);
  }
}

// The series check against the conditions written out: Σγ = 1, Σγ³ = 0 (order 4), Σγ⁵ = 0
// (needed for order 6); the built-ins' power sums vanish exactly as far as their orders need.
TEST(Composition, OrderCheckAgreesWithTheClosedFormConditions) {
  for (const std::string& name : composition_names()) {
    SCOPED_TRACE(name);
    const Composition& c = builtin_composition(name);
    EXPECT_NEAR(power_sum(c.weights, 3), 0.0, 1e-14);
    for (int power : {5, 7}) {
      if (c.order > power) {
        EXPECT_NEAR(power_sum(c.weights, power), 0.0, 1e-14) << power;
      } else if (c.order == power - 1) {
        EXPECT_GT(std::abs(power_sum(c.weights, power)), 1e-3) << power;
      }
    }
  }
  // Symmetric, Σγ = 1 but Σγ³ ≠ 0: order 2 only.
  EXPECT_EQ(satisfied_composition_order({0.25, 0.5, 0.25}), 2);
  EXPECT_EQ(satisfied_composition_order({1.0}), 2);
}

TEST(Composition, MistypedDigitsAndFalseClaimsAreRefused) {
  // One digit off in the 9th place of a weight pair (the middle weight keeps the sum 1).
  std::vector<double> w = builtin_composition("kahan-li8").weights;
  w[2] += 1e-9, w[14] += 1e-9, w[8] -= 2e-9;
  EXPECT_EQ(composition_problem(w, 2), "");
  const std::string problem = composition_problem(w, 8);
  EXPECT_NE(problem.find("claim order 8 but meet the composition order conditions only to order 2"),
            std::string::npos)
      << problem;

  EXPECT_NE(composition_problem(builtin_composition("yoshida4").weights, 6).find("only to order 4"),
            std::string::npos);
  EXPECT_NE(composition_problem({0.3, 0.7}, 2).find("must be symmetric"), std::string::npos);
  EXPECT_NE(composition_problem({0.5, 0.6, 0.5}, 2).find("must sum to 1, but they sum to 1.6"), std::string::npos);
  EXPECT_NE(composition_problem({}, 2).find("no weights"), std::string::npos);
  EXPECT_NE(composition_problem({0.5, NAN, 0.5}, 2).find("finite"), std::string::npos);
  EXPECT_NE(composition_problem({1.0}, 3).find("even order"), std::string::npos);
}

TEST(Composition, ResolvesTheRunFilesChoice) {
  IntegratorConfig config;
  EXPECT_EQ(resolve_composition(config).weights, std::vector<double>{1.0});
  config.composition = "suzuki4";
  EXPECT_EQ(resolve_composition(config).stages(), 5);
  config.composition = "user";
  config.composition_weights = builtin_composition("kahan-li6").weights;
  config.composition_order = 6;
  EXPECT_EQ(resolve_composition(config).weights, config.composition_weights);
  config.composition_order = 8;
  try {
    resolve_composition(config);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("composition_weights: the weights claim order 8"), std::string::npos) << what;
  }
  config.composition = "trotter";
  EXPECT_THROW(resolve_composition(config), InputError);
}

// The run file offers "none", the built-ins and "user".
TEST(Composition, TheRunFileOffersExactlyTheBuiltins) {
  const ConfigKey* key = run_schema().find("integrator", "composition");
  ASSERT_NE(key, nullptr);
  std::vector<std::string> expected = {"none"};
  for (const std::string& name : composition_names()) expected.push_back(name);
  expected.push_back("user");
  EXPECT_EQ(key->choices, expected);
}

}  // namespace
}  // namespace vimd
