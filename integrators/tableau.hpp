#pragma once
// Explicit Runge–Kutta methods as data (Butcher tableaus), the built-in ones, and the checks a
// user tableau must pass: sizes, explicitness, row sums c_i = Σ_j a_ij, and the rooted-tree order
// conditions Σ_i b_i Φ_i(t) = 1/γ(t) for every tree t up to the claimed order.
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Dense>

#include "integrators/settings.hpp"

namespace vimd {

struct ButcherTableau {
  std::string name;
  int order = 0;      // claimed (and checked) classical order
  Eigen::MatrixXd a;  // s×s, strictly lower triangular
  Eigen::VectorXd b, c;
  int stages() const { return static_cast<int>(b.size()); }
};

std::vector<std::string> tableau_names();
// A built-in tableau; std::out_of_range (listing the names) for an unknown one.
const ButcherTableau& builtin_tableau(const std::string& name);

// Everything wrong with the structure (sizes, non-finite entries, an explicit method needs a
// strictly lower-triangular a, consistency c_i = Σ_j a_ij), or an empty string.
std::string tableau_structure_problem(const ButcherTableau& tableau, double tolerance = 1e-12);

struct OrderCondition {
  int order = 0;
  std::string tree;     // bracket notation: "t" is the single node, "[t t]" a root with two leaves
  std::string formula;  // e.g. "sum b_i a_ij c_j = 1/6"
  double gamma = 1;     // the condition is Σ b_i Φ_i = 1/gamma
  double value = 0;     // Σ b_i Φ_i for the tableau at hand
};

// All rooted trees of order 1..max_order as conditions (value left 0); orders 1..8 have
// 1, 1, 2, 4, 9, 20, 48, 115 trees.
std::vector<OrderCondition> order_conditions(int max_order);
// The first condition of order ≤ max_order violated by more than `tolerance` relative to 1/γ.
std::optional<OrderCondition> first_failing_order_condition(const ButcherTableau& tableau, int max_order,
                                                            double tolerance = 1e-10);
// The largest p ≤ max_order whose conditions all hold.
int satisfied_order(const ButcherTableau& tableau, int max_order = 8);

// A user tableau from [integrator.tableau], checked; InputError(file, config.line, problem) on failure.
ButcherTableau tableau_from_config(const TableauConfig& config, const std::string& file);
// `method` is a built-in name or "user" (then config.tableau must be present); InputError otherwise.
ButcherTableau resolve_tableau(const std::string& method, const IntegratorConfig& config,
                               const std::string& file = "[integrator]");

}  // namespace vimd
