#include "integrators/tableau.hpp"

#include <cmath>
#include <cstdio>
#include <map>
#include <stdexcept>

#include "engine/errors.hpp"

namespace vimd {

namespace {

ButcherTableau make(std::string name, int order, std::vector<std::vector<double>> a, std::vector<double> b,
                    std::vector<double> c) {
  ButcherTableau t;
  t.name = std::move(name);
  t.order = order;
  const int s = static_cast<int>(b.size());
  t.a.setZero(s, s);
  for (int i = 0; i < s; ++i)
    for (int j = 0; j < static_cast<int>(a[i].size()); ++j) t.a(i, j) = a[i][j];
  t.b = Eigen::Map<Eigen::VectorXd>(b.data(), s);
  t.c = Eigen::Map<Eigen::VectorXd>(c.data(), s);
  return t;
}

const std::map<std::string, ButcherTableau>& builtins() {
  static const std::map<std::string, ButcherTableau> table = [] {
    std::map<std::string, ButcherTableau> m;
    auto add = [&m](ButcherTableau t) { m.emplace(t.name, std::move(t)); };
    add(make("euler", 1, {{}}, {1.0}, {0.0}));
    add(make("heun2", 2, {{}, {1.0}}, {0.5, 0.5}, {0.0, 1.0}));
    add(make("midpoint", 2, {{}, {0.5}}, {0.0, 1.0}, {0.0, 0.5}));
    // Kutta's third-order method.
    add(make("rk3", 3, {{}, {0.5}, {-1.0, 2.0}}, {1.0 / 6, 2.0 / 3, 1.0 / 6}, {0.0, 0.5, 1.0}));
    add(make("rk4", 4, {{}, {0.5}, {0.0, 0.5}, {0.0, 0.0, 1.0}}, {1.0 / 6, 1.0 / 3, 1.0 / 3, 1.0 / 6},
             {0.0, 0.5, 0.5, 1.0}));
    // Kutta's 3/8 rule.
    add(make("rk38", 4, {{}, {1.0 / 3}, {-1.0 / 3, 1.0}, {1.0, -1.0, 1.0}}, {1.0 / 8, 3.0 / 8, 3.0 / 8, 1.0 / 8},
             {0.0, 1.0 / 3, 2.0 / 3, 1.0}));
    // Butcher's 7-stage method of order 6 (Butcher, Numerical Methods for ODEs, §324).
    add(make("rk6", 6,
             {{},
              {1.0 / 3},
              {0.0, 2.0 / 3},
              {1.0 / 12, 1.0 / 3, -1.0 / 12},
              {-1.0 / 16, 9.0 / 8, -3.0 / 16, -3.0 / 8},
              {0.0, 9.0 / 8, -3.0 / 8, -3.0 / 4, 1.0 / 2},
              {9.0 / 44, -9.0 / 11, 63.0 / 44, 18.0 / 11, 0.0, -16.0 / 11}},
             {11.0 / 120, 0.0, 27.0 / 40, 27.0 / 40, -4.0 / 15, -4.0 / 15, 11.0 / 120},
             {0.0, 1.0 / 3, 2.0 / 3, 1.0 / 3, 1.0 / 2, 1.0 / 2, 1.0}));
    // Cooper & Verner's 11-stage method of order 8 (G. J. Cooper, J. H. Verner, "Some explicit
    // Runge-Kutta methods of high order", SIAM J. Numer. Anal. 9 (1972) 389-405); r = sqrt(21).
    const double r = std::sqrt(21.0);
    add(make("rk8", 8,
             {{},
              {1.0 / 2},
              {1.0 / 4, 1.0 / 4},
              {1.0 / 7, (-7 - 3 * r) / 98, (21 + 5 * r) / 49},
              {(11 + r) / 84, 0.0, (18 + 4 * r) / 63, (21 - r) / 252},
              {(5 + r) / 48, 0.0, (9 + r) / 36, (-231 + 14 * r) / 360, (63 - 7 * r) / 80},
              {(10 - r) / 42, 0.0, (-432 + 92 * r) / 315, (633 - 145 * r) / 90, (-504 + 115 * r) / 70,
               (63 - 13 * r) / 35},
              {1.0 / 14, 0.0, 0.0, 0.0, (14 - 3 * r) / 126, (13 - 3 * r) / 63, 1.0 / 9},
              {1.0 / 32, 0.0, 0.0, 0.0, (91 - 21 * r) / 576, 11.0 / 72, (-385 - 75 * r) / 1152, (63 + 13 * r) / 128},
              {1.0 / 14, 0.0, 0.0, 0.0, 1.0 / 9, (-733 - 147 * r) / 2205, (515 + 111 * r) / 504, (-51 - 11 * r) / 56,
               (132 + 28 * r) / 245},
              {0.0, 0.0, 0.0, 0.0, (-42 + 7 * r) / 18, (-18 + 28 * r) / 45, (-273 - 53 * r) / 72, (301 + 53 * r) / 72,
               (28 - 28 * r) / 45, (49 - 7 * r) / 18}},
             {1.0 / 20, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 49.0 / 180, 16.0 / 45, 49.0 / 180, 1.0 / 20},
             {0.0, 1.0 / 2, 1.0 / 2, (7 + r) / 14, (7 + r) / 14, 1.0 / 2, (7 - r) / 14, (7 - r) / 14, 1.0 / 2,
              (7 + r) / 14, 1.0}));
    // A mistyped coefficient must not pass as a lower-order method: check every claim once.
    for (const auto& [name, t] : m)
      if (auto failing = first_failing_order_condition(t, t.order))
        throw std::logic_error("built-in tableau " + name + " violates the order-" + std::to_string(failing->order) +
                               " condition " + failing->formula);
    return m;
  }();
  return table;
}

// Rooted trees, each a root with a non-decreasing list of child tree ids; ids grow with order.
struct Tree {
  int order;
  std::vector<int> children;
};

constexpr int kMaxTreeOrder = 10;

// All trees of order ≤ kMaxTreeOrder (1205 of them), generated once.
std::vector<Tree> generate_trees() {
  std::vector<Tree> trees{{1, {}}};
  for (int n = 2; n <= kMaxTreeOrder; ++n) {
    // Multisets of subtrees with orders summing to n − 1, as non-decreasing id sequences; the
    // trees of order n appended meanwhile stop the scan, so only lower orders are children.
    std::vector<int> current;
    auto extend = [&](auto&& self, int remaining, int min_id) -> void {
      if (remaining == 0) {
        trees.push_back({n, current});
        return;
      }
      for (int id = min_id; id < static_cast<int>(trees.size()) && trees[id].order < n; ++id) {
        if (trees[id].order > remaining) continue;
        current.push_back(id);
        self(self, remaining - trees[id].order, id);
        current.pop_back();
      }
    };
    extend(extend, n - 1, 0);
  }
  return trees;
}

const std::vector<Tree>& trees_up_to(int max_order) {
  static const std::vector<Tree> trees = generate_trees();
  if (max_order > kMaxTreeOrder)
    throw std::invalid_argument("order conditions are generated up to order " + std::to_string(kMaxTreeOrder));
  return trees;
}

std::string tree_notation(const std::vector<Tree>& trees, int id) {
  if (trees[id].children.empty()) return "t";
  std::string s = "[";
  for (std::size_t k = 0; k < trees[id].children.size(); ++k) {
    if (k) s += ' ';
    s += tree_notation(trees, trees[id].children[k]);
  }
  return s + "]";
}

// Factors of the elementary weight Φ at node index `x`: leaves give c_x, other children a_xy Φ_y.
std::string weight_factors(const std::vector<Tree>& trees, int id, char x, char& next_index) {
  std::string s;
  int leaves = 0;
  for (int child : trees[id].children) leaves += trees[child].children.empty();
  if (leaves) s += std::string(" c_") + x + (leaves > 1 ? "^" + std::to_string(leaves) : "");
  for (int child : trees[id].children) {
    if (trees[child].children.empty()) continue;
    const char y = next_index++;
    s += std::string(" a_") + x + y + weight_factors(trees, child, y, next_index);
  }
  return s;
}

double tree_gamma(const std::vector<Tree>& trees, int id) {
  double g = trees[id].order;
  for (int child : trees[id].children) g *= tree_gamma(trees, child);
  return g;
}

OrderCondition describe(const std::vector<Tree>& trees, int id) {
  OrderCondition c;
  c.order = trees[id].order;
  c.tree = tree_notation(trees, id);
  char next = 'j';
  c.gamma = tree_gamma(trees, id);
  char buf[32];
  std::snprintf(buf, sizeof buf, "1/%.0f", c.gamma);
  c.formula = "sum b_i" + weight_factors(trees, id, 'i', next) + " = " + buf;
  return c;
}

}  // namespace

std::vector<std::string> tableau_names() {
  std::vector<std::string> names;
  for (const auto& [name, t] : builtins()) names.push_back(name);
  return names;
}

const ButcherTableau& builtin_tableau(const std::string& name) {
  auto it = builtins().find(name);
  if (it == builtins().end()) {
    std::string known;
    for (const auto& n : tableau_names()) known += (known.empty() ? "" : ", ") + n;
    throw std::out_of_range("unknown tableau '" + name + "' (built-in: " + known + ")");
  }
  return it->second;
}

std::string tableau_structure_problem(const ButcherTableau& t, double tolerance) {
  const int s = t.stages();
  if (s == 0) return "the tableau has no stages (b is empty)";
  if (t.a.rows() != s || t.a.cols() != s)
    return "a must be " + std::to_string(s) + "x" + std::to_string(s) + " to match the " + std::to_string(s) +
           " weights in b, but it is " + std::to_string(t.a.rows()) + "x" + std::to_string(t.a.cols());
  if (t.c.size() != s)
    return "c has " + std::to_string(t.c.size()) + " entries but b has " + std::to_string(s);
  if (!t.a.allFinite() || !t.b.allFinite() || !t.c.allFinite()) return "the tableau has a non-finite entry";
  for (int i = 0; i < s; ++i)
    for (int j = i; j < s; ++j)
      if (t.a(i, j) != 0)
        return "a(" + std::to_string(i + 1) + "," + std::to_string(j + 1) + ") = " + std::to_string(t.a(i, j)) +
               " is on or above the diagonal; only explicit methods (strictly lower-triangular a) are supported";
  for (int i = 0; i < s; ++i) {
    const double row = t.a.row(i).sum();
    if (std::abs(row - t.c(i)) > tolerance * std::max(1.0, std::abs(t.c(i)))) {
      char buf[160];
      std::snprintf(buf, sizeof buf, "c(%d) = %.17g but row %d of a sums to %.17g (need c_i = sum_j a_ij)", i + 1,
                    t.c(i), i + 1, row);
      return buf;
    }
  }
  return "";
}

std::vector<OrderCondition> order_conditions(int max_order) {
  const auto& trees = trees_up_to(max_order);
  std::vector<OrderCondition> out;
  for (int id = 0; id < static_cast<int>(trees.size()) && trees[id].order <= max_order; ++id)
    out.push_back(describe(trees, id));
  return out;
}

std::optional<OrderCondition> first_failing_order_condition(const ButcherTableau& t, int max_order,
                                                            double tolerance) {
  const auto& trees = trees_up_to(max_order);
  const int s = t.stages();
  // Elementary weights Φ(t) ∈ R^s, by tree id (children have smaller ids).
  std::vector<Eigen::VectorXd> phi;
  for (int id = 0; id < static_cast<int>(trees.size()) && trees[id].order <= max_order; ++id) {
    Eigen::VectorXd w = Eigen::VectorXd::Ones(s);
    for (int child : trees[id].children) w.array() *= (t.a * phi[child]).array();
    phi.push_back(w);
    const double value = t.b.dot(w);
    const double gamma = tree_gamma(trees, id);
    if (!(std::abs(value * gamma - 1.0) <= tolerance)) {
      OrderCondition c = describe(trees, id);
      c.value = value;
      return c;
    }
  }
  return std::nullopt;
}

int satisfied_order(const ButcherTableau& t, int max_order) {
  auto failing = first_failing_order_condition(t, max_order);
  return failing ? failing->order - 1 : max_order;
}

ButcherTableau tableau_from_config(const TableauConfig& config, const std::string& file) {
  auto fail = [&](const std::string& problem) { throw InputError(file, config.line, "[integrator.tableau]: " + problem); };
  ButcherTableau t;
  t.name = "user";
  t.order = config.order;
  const int s = static_cast<int>(config.b.size());
  if (config.order < 1) fail("order must be given as a positive integer (the order the tableau claims)");
  if (config.order > kMaxTreeOrder)
    fail("order " + std::to_string(config.order) + " is above " + std::to_string(kMaxTreeOrder) +
         ", the highest order whose conditions are checked");
  if (static_cast<int>(config.a.size()) != s)
    fail("a has " + std::to_string(config.a.size()) + " rows but b has " + std::to_string(s) + " weights");
  t.a.setZero(s, s);
  for (int i = 0; i < s; ++i) {
    if (static_cast<int>(config.a[i].size()) != s)
      fail("row " + std::to_string(i + 1) + " of a has " + std::to_string(config.a[i].size()) + " entries, expected " +
           std::to_string(s));
    for (int j = 0; j < s; ++j) t.a(i, j) = config.a[i][j];
  }
  t.b = Eigen::Map<const Eigen::VectorXd>(config.b.data(), s);
  t.c = Eigen::Map<const Eigen::VectorXd>(config.c.data(), static_cast<Eigen::Index>(config.c.size()));
  if (auto problem = tableau_structure_problem(t); !problem.empty()) fail(problem);
  if (auto failing = first_failing_order_condition(t, t.order)) {
    char buf[96];
    std::snprintf(buf, sizeof buf, " (the tableau gives %.17g, relative tolerance 1e-10)", failing->value);
    fail("the tableau claims order " + std::to_string(t.order) + " but violates the order-" +
         std::to_string(failing->order) + " condition for tree " + failing->tree + ": " + failing->formula + buf);
  }
  return t;
}

ButcherTableau resolve_tableau(const std::string& method, const IntegratorConfig& config, const std::string& file) {
  if (method == "user") {
    if (!config.tableau)
      throw SettingError("integrator", "method",
                         "method = \"user\" needs an [integrator.tableau] table with a, b, c, order");
    return tableau_from_config(*config.tableau, file);
  }
  try {
    return builtin_tableau(method);
  } catch (const std::out_of_range& e) {
    throw SettingError("integrator", "method",
                       std::string(e.what()) + "; or method = \"user\" with [integrator.tableau]");
  }
}

}  // namespace vimd
