#pragma once
// Per-atom (per-column) loops and vector operations shared by the integrators, with OpenMP inside, so
// that the code using them reads as the mathematics it computes.
#include <cmath>
#include <limits>
#include <utility>

#include "engine/types.hpp"

namespace vimd {

// f(i) for i = 0..n−1, in parallel (static partition).
template <class F>
void parallel_for(int n, F&& f) {
#pragma omp parallel for schedule(static) if (n >= kParallelMinAtoms)
  for (int i = 0; i < n; ++i) f(i);
}

// f(i) for every atom i, in parallel.
template <class F>
void for_each_atom(int n, F&& f) {
  parallel_for(n, std::forward<F>(f));
}

// Σ_i term(i) for i = 0..n−1, in parallel. The static partition makes the summation order depend
// on the thread count alone, so a run repeats bit for bit at the same thread count.
template <class Term>
double parallel_sum(int n, Term&& term) {
  double sum = 0;
#pragma omp parallel for schedule(static) reduction(+ : sum) if (n >= kParallelMinAtoms)
  for (int i = 0; i < n; ++i) sum += term(i);
  return sum;
}

// dst = expr (any Eigen expression of dst's shape, dst already sized), atoms in parallel. Column-wise
// evaluation makes expressions that read dst itself (dst = −dst, dst += u) safe.
template <class Expr>
void parallel_assign(Coords& dst, const Expr& expr) {
  for_each_atom(static_cast<int>(dst.cols()), [&](int i) { dst.col(i) = expr.col(i); });
}

// u with atom i's column scaled by s[i] (M v, M⁻¹ p, ...), an expression for parallel_assign.
template <class Expr>
auto scaled_per_atom(const Eigen::VectorXd& s, const Expr& u) {
  return u * s.asDiagonal();
}

// max_i scale(i)·‖u_i‖_∞, or +∞ when any entry is not finite (so a NaN never passes a test).
template <class Scale>
double max_abs_scaled(const Coords& u, Scale&& scale) {
  const int n = static_cast<int>(u.cols());
  double m = 0;
  bool finite = true;
#pragma omp parallel for schedule(static) reduction(max : m) reduction(&& : finite) if (n >= kParallelMinAtoms)
  for (int i = 0; i < n; ++i) {
    const double x = scale(i) * u.col(i).cwiseAbs().maxCoeff();
    finite = finite && std::isfinite(x);
    m = std::max(m, x);
  }
  return finite ? m : std::numeric_limits<double>::infinity();
}

inline double max_abs(const Coords& u) {
  return max_abs_scaled(u, [](int) { return 1.0; });
}

}  // namespace vimd
