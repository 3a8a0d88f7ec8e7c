// Butcher tableaus: the built-ins have exactly their stated order, the rooted-tree conditions are
// generated correctly, and a bad user tableau is refused with a message naming the problem.
#include <gtest/gtest.h>

#include <cmath>

#include "engine/errors.hpp"
#include "integrators/tableau.hpp"

namespace vimd {
namespace {

TEST(Tableau, TreeCountsMatchTheKnownSequence) {
  // Number of rooted trees with n nodes (OEIS A000081).
  const int expected[] = {1, 1, 2, 4, 9, 20, 48, 115, 286, 719};
  auto conditions = order_conditions(10);
  for (int n = 1; n <= 10; ++n) {
    int count = 0;
    for (const auto& c : conditions) count += c.order == n;
    EXPECT_EQ(count, expected[n - 1]) << "order " << n;
  }
}

TEST(Tableau, ConditionsOfOrderThreeAreTheTextbookOnes) {
  auto conditions = order_conditions(3);
  ASSERT_EQ(conditions.size(), 4u);
  EXPECT_EQ(conditions[0].formula, "sum b_i = 1/1");
  EXPECT_EQ(conditions[1].formula, "sum b_i c_i = 1/2");
  EXPECT_EQ(conditions[1].tree, "[t]");
  // The two order-3 trees in either order.
  std::vector<std::string> f3 = {conditions[2].formula, conditions[3].formula};
  std::sort(f3.begin(), f3.end());
  EXPECT_EQ(f3[0], "sum b_i a_ij c_j = 1/6");
  EXPECT_EQ(f3[1], "sum b_i c_i^2 = 1/3");
}

TEST(Tableau, BuiltinsHaveExactlyTheirOrder) {
  const std::map<std::string, int> expected = {{"euler", 1}, {"heun2", 2}, {"midpoint", 2}, {"rk3", 3},
                                                {"rk4", 4},   {"rk38", 4},  {"rk6", 6},     {"rk8", 8}};
  for (const auto& name : tableau_names()) {
    SCOPED_TRACE(name);
    const ButcherTableau& t = builtin_tableau(name);
    ASSERT_TRUE(expected.count(name)) << "a new built-in needs an expected order here";
    EXPECT_EQ(t.order, expected.at(name));
    EXPECT_EQ(tableau_structure_problem(t), "");
    // One order above the claim must fail: the stated order is exact.
    EXPECT_EQ(satisfied_order(t, t.order + 1), t.order);
  }
  EXPECT_GE(builtin_tableau("rk6").order, 6);
  EXPECT_EQ(builtin_tableau("rk8").stages(), 11);
}

TEST(Tableau, UnknownBuiltinListsTheNames) {
  try {
    builtin_tableau("rk5");
    FAIL() << "expected std::out_of_range";
  } catch (const std::out_of_range& e) {
    EXPECT_NE(std::string(e.what()).find("rk4"), std::string::npos);
  }
}

TableauConfig ralston() {
  TableauConfig c;
  c.a = {{0, 0}, {2.0 / 3, 0}};
  c.b = {0.25, 0.75};
  c.c = {0, 2.0 / 3};
  c.order = 2;
  c.line = 17;
  return c;
}

std::string user_error(const TableauConfig& config) {
  try {
    tableau_from_config(config, "run.toml");
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), "run.toml");
    EXPECT_EQ(e.line(), 17);
    return e.what();
  }
  ADD_FAILURE() << "the tableau was accepted";
  return "";
}

TEST(Tableau, ValidUserTableauIsAccepted) {
  ButcherTableau t = tableau_from_config(ralston(), "run.toml");
  EXPECT_EQ(t.stages(), 2);
  EXPECT_EQ(t.order, 2);
  EXPECT_EQ(satisfied_order(t), 2);
}

TEST(Tableau, ImplicitUserTableauIsRefused) {
  auto c = ralston();
  c.a[0][1] = 0.1;
  c.c[0] = 0.1;
  EXPECT_NE(user_error(c).find("a(1,2)"), std::string::npos);
}

TEST(Tableau, InconsistentRowSumIsRefused) {
  auto c = ralston();
  c.c[1] = 0.5;
  EXPECT_NE(user_error(c).find("c(2)"), std::string::npos);
}

TEST(Tableau, WrongSizesAreRefused) {
  auto c = ralston();
  c.c = {0};
  EXPECT_NE(user_error(c).find("c has 1 entries"), std::string::npos);
  c = ralston();
  c.a[1] = {2.0 / 3};
  EXPECT_NE(user_error(c).find("row 2 of a"), std::string::npos);
  c = ralston();
  c.order = 0;
  EXPECT_NE(user_error(c).find("order"), std::string::npos);
}

TEST(Tableau, OverclaimedOrderNamesTheFirstFailingCondition) {
  auto c = ralston();
  c.order = 3;
  const std::string message = user_error(c);
  EXPECT_NE(message.find("order-3 condition"), std::string::npos) << message;
  // Ralston happens to satisfy sum b_i c_i^2 = 1/3; the other order-3 tree fails.
  EXPECT_NE(message.find("[[t]]: sum b_i a_ij c_j = 1/6"), std::string::npos) << message;

  // rk4 with a perturbed weight loses order 1 already.
  TableauConfig rk4;
  const ButcherTableau& t = builtin_tableau("rk4");
  rk4.a.assign(4, std::vector<double>(4));
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) rk4.a[i][j] = t.a(i, j);
  rk4.b = {t.b.data(), t.b.data() + 4};
  rk4.c = {t.c.data(), t.c.data() + 4};
  rk4.order = 4;
  rk4.line = 17;
  EXPECT_NO_THROW(tableau_from_config(rk4, "run.toml"));
  rk4.order = 5;
  EXPECT_NE(user_error(rk4).find("order-5 condition"), std::string::npos);
  rk4.order = 4;
  rk4.b[0] += 1e-6;
  EXPECT_NE(user_error(rk4).find("sum b_i = 1/1"), std::string::npos);
}

TEST(Tableau, CooperVernerAsUserTableauIsCheckedToOrderEight) {
  // All 200 conditions up to order 8 hold to the 1e-10 tolerance in double precision (the
  // coefficients involve sqrt(21)); a perturbed coefficient is refused.
  const ButcherTableau& t = builtin_tableau("rk8");
  TableauConfig config;
  const int s = t.stages();
  config.a.assign(s, std::vector<double>(s));
  for (int i = 0; i < s; ++i)
    for (int j = 0; j < s; ++j) config.a[i][j] = t.a(i, j);
  config.b = {t.b.data(), t.b.data() + s};
  config.c = {t.c.data(), t.c.data() + s};
  config.order = 8;
  config.line = 17;
  EXPECT_EQ(order_conditions(8).size(), 200u);
  EXPECT_NO_THROW(tableau_from_config(config, "run.toml"));
  config.a[10][4] += 1e-7;
  config.a[10][0] -= 1e-7;  // keeps the row sum c_11 = 1
  EXPECT_NE(user_error(config).find("claims order 8 but violates"), std::string::npos);
}

TEST(Tableau, ResolveByNameOrUser) {
  IntegratorConfig config;
  EXPECT_EQ(resolve_tableau("rk38", config).name, "rk38");
  EXPECT_THROW(resolve_tableau("user", config), InputError);
  EXPECT_THROW(resolve_tableau("nonsense", config), InputError);
  config.tableau = ralston();
  EXPECT_EQ(resolve_tableau("user", config).stages(), 2);
}

}  // namespace
}  // namespace vimd
