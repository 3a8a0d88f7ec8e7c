#include "integrators/composition.hpp"

#include <cmath>
#include <cstdio>
#include <random>
#include <stdexcept>

#include <Eigen/Dense>

#include "engine/errors.hpp"

namespace vimd {

namespace {

constexpr int kMaxOrder = 10;
// Relative: the weights' round-off shows at ~1e-16, a mistyped digit far above.
constexpr double kTolerance = 1e-12;

// γ_1 … γ_m given, the rest mirrored: γ_{s+1−k} = γ_k with s = 2m − 1 (γ_m in the middle).
Composition symmetric(std::string name, int order, std::vector<double> half) {
  Composition c{std::move(name), order, half};
  for (int k = static_cast<int>(half.size()) - 2; k >= 0; --k) c.weights.push_back(half[k]);
  return c;
}

const std::vector<Composition>& builtins() {
  static const std::vector<Composition> table = [] {
    std::vector<Composition> v;
    // The triple jump: H. Yoshida, "Construction of higher order symplectic integrators",
    // Phys. Lett. A 150 (1990) 262-268 (x1 = 1/(2 - 2^(1/3)), x0 = -2^(1/3) x1); Hairer, Lubich &
    // Wanner, Geometric Numerical Integration, 2nd ed. (2006), §II.4.
    const double triple = 1 / (2 - std::cbrt(2.0));
    v.push_back(symmetric("yoshida4", 4, {triple, -std::cbrt(2.0) * triple}));
    // Suzuki's fractal: M. Suzuki, "Fractal decomposition of exponential operators with
    // applications to many-body theories and Monte Carlo simulations", Phys. Lett. A 146 (1990)
    // 319-323 (p = 1/(4 - 4^(1/3)), four sub-steps p and 1 - 4p in the middle); GNI §II.4.
    const double fractal = 1 / (4 - std::cbrt(4.0));
    v.push_back(symmetric("suzuki4", 4, {fractal, fractal, -std::cbrt(4.0) * fractal}));
    // W. Kahan, R.-C. Li, "Composition constants for raising the orders of unconventional schemes
    // for ordinary differential equations", Math. Comp. 66 (1997) 1089-1099: s9odr6a and
    // s17odr8a, with the digits printed in GNI §V.3.2 (p6 s9, p8 s17).
    v.push_back(symmetric("kahan-li6", 6,
                          {0.39216144400731413927925056, 0.33259913678935943859974864,
                           -0.70624617255763935980996482, 0.08221359629355080023149045,
                           0.79854399093482996339895035}));
    v.push_back(symmetric("kahan-li8", 8,
                          {0.13020248308889008087881763, 0.56116298177510838456196441,
                           -0.38947496264484728640807860, 0.15884190655515560089621075,
                           -0.39590389413323757733623154, 0.18453964097831570709183254,
                           0.25837438768632204729397911, 0.29501172360931029887096624,
                           -0.60550853383003451169892108}));
    // A mistyped digit must not pass as a lower-order method: check every claim once.
    for (const Composition& c : v)
      if (auto problem = composition_problem(c.weights, c.order); !problem.empty())
        throw std::logic_error("built-in composition " + c.name + ": " + problem);
    return v;
  }();
  return table;
}

// Power series in h with matrix coefficients, truncated after h^(size − 1).
using Series = std::vector<Eigen::MatrixXd>;

Series product(const Series& a, const Series& b) {
  Series out(a.size(), Eigen::MatrixXd::Zero(a[0].rows(), a[0].cols()));
  for (std::size_t i = 0; i < a.size(); ++i)
    for (std::size_t j = 0; i + j < a.size(); ++j) out[i + j] += a[i] * b[j];
  return out;
}

// exp(x) for a series without a constant term.
Series exponential(const Series& x) {
  const Eigen::Index n = x[0].rows();
  Series sum(x.size(), Eigen::MatrixXd::Zero(n, n)), term = sum;
  sum[0] = term[0] = Eigen::MatrixXd::Identity(n, n);
  for (std::size_t k = 1; k < x.size(); ++k) {
    term = product(term, x);
    for (auto& c : term) c /= static_cast<double>(k);
    for (std::size_t m = 0; m < x.size(); ++m) sum[m] += term[m];
  }
  return sum;
}

// The coefficients of h^1 … h^max_order of Ψ_h − exp(hA), each relative to (Σ|γ_k|)^m / m!.
std::vector<double> expansion_defects(const std::vector<double>& weights, int max_order) {
  constexpr int n = 6;
  std::mt19937_64 random(2024);  // fixed: the same generic matrices on every machine
  auto generic = [&] {
    Eigen::MatrixXd m(n, n);
    for (Eigen::Index k = 0; k < m.size(); ++k)
      m.data()[k] = (static_cast<double>(random() >> 11) * 0x1.0p-53 * 2 - 1) / std::sqrt(double(n));
    return m;
  };
  std::vector<Eigen::MatrixXd> field;  // A, B, C, …: the coefficients of h, h³, h⁵, …
  for (int power = 1; power <= max_order; power += 2) field.push_back(generic());

  const std::size_t terms = static_cast<std::size_t>(max_order) + 1;
  auto flow = [&](double gamma) {  // exp(γhA + (γh)³B + …)
    Series x(terms, Eigen::MatrixXd::Zero(n, n));
    for (std::size_t j = 0; j < field.size(); ++j) x[2 * j + 1] = std::pow(gamma, 2 * j + 1) * field[j];
    return exponential(x);
  };
  Series psi(terms, Eigen::MatrixXd::Zero(n, n));
  psi[0] = Eigen::MatrixXd::Identity(n, n);
  double total = 0;
  for (double gamma : weights) psi = product(flow(gamma), psi), total += std::abs(gamma);
  Series exact(terms, Eigen::MatrixXd::Zero(n, n));
  exact[1] = field[0];
  exact = exponential(exact);

  std::vector<double> defects;
  double scale = 1;
  for (int m = 1; m <= max_order; ++m) {
    scale *= total / m;
    defects.push_back((psi[m] - exact[m]).cwiseAbs().maxCoeff() / scale);
  }
  return defects;
}

std::string number(double x) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3g", x);
  return buf;
}

}  // namespace

std::vector<std::string> composition_names() {
  std::vector<std::string> names;
  for (const Composition& c : builtins()) names.push_back(c.name);
  return names;
}

const Composition& builtin_composition(const std::string& name) {
  for (const Composition& c : builtins())
    if (c.name == name) return c;
  std::string known;
  for (const auto& n : composition_names()) known += (known.empty() ? "" : ", ") + n;
  throw std::out_of_range("unknown composition '" + name + "' (built-in: " + known + ")");
}

int satisfied_composition_order(const std::vector<double>& weights, int max_order) {
  max_order = std::min(max_order, kMaxOrder);
  const std::vector<double> defects = expansion_defects(weights, max_order);
  int order = 0;
  while (order < max_order && defects[order] <= kTolerance) ++order;
  return order - order % 2;
}

std::string composition_problem(const std::vector<double>& weights, int order) {
  const int s = static_cast<int>(weights.size());
  if (s == 0) return "there are no weights";
  double largest = 0, sum = 0, total = 0;
  for (double w : weights) {
    if (!std::isfinite(w)) return "the weights must be finite numbers";
    largest = std::max(largest, std::abs(w)), sum += w, total += std::abs(w);
  }
  for (int k = 0; k < s / 2; ++k)
    if (std::abs(weights[k] - weights[s - 1 - k]) > kTolerance * largest)
      return "the weights must be symmetric (weight " + std::to_string(k + 1) + " equal to weight " +
             std::to_string(s - k) + "), but they are " + number(weights[k]) + " and " + number(weights[s - 1 - k]);
  if (std::abs(sum - 1) > kTolerance * total) return "the weights must sum to 1, but they sum to " + number(sum);
  if (order < 2 || order > kMaxOrder || order % 2)
    return "the claimed order must be 2, 4, 6, 8 or 10 (a symmetric composition has even order), got " +
           std::to_string(order);
  const std::vector<double> defects = expansion_defects(weights, order);
  for (int m = 1; m <= order; ++m)
    if (defects[m - 1] > kTolerance)
      return "the weights claim order " + std::to_string(order) +
             " but meet the composition order conditions only to order " + std::to_string(m - 1 - (m - 1) % 2) +
             " (the composed step's h^" + std::to_string(m) + " term is off by " + number(defects[m - 1]) +
             " relative, tolerance " + number(kTolerance) + ")";
  return "";
}

Composition resolve_composition(const IntegratorConfig& config) {
  if (config.composition == "none") return {"none", 2, {1.0}};
  if (config.composition == "user") {
    if (auto problem = composition_problem(config.composition_weights, config.composition_order); !problem.empty())
      throw SettingError("integrator", "composition_weights", "composition_weights: " + problem);
    return {"user", config.composition_order, config.composition_weights};
  }
  try {
    return builtin_composition(config.composition);
  } catch (const std::out_of_range& e) {
    throw SettingError("integrator", "composition",
                       std::string(e.what()) + "; or composition = \"user\" with composition_weights");
  }
}

}  // namespace vimd
