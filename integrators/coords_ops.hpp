#pragma once
// Per-atom loops shared by the variational integrator's building blocks, with OpenMP.
#include <cmath>
#include <limits>

#include "engine/types.hpp"

namespace vimd {

// Below this many atoms a loop runs on one thread: starting a team costs more than the work.
constexpr int kParallelMinAtoms = 256;

// f(i) for every atom i, in parallel.
template <class F>
void for_each_atom(int n, F&& f) {
#pragma omp parallel for schedule(static) if (n >= kParallelMinAtoms)
  for (int i = 0; i < n; ++i) f(i);
}

// dst = expr (any Eigen expression of dst's shape, dst already sized), atoms in parallel. Column-wise
// evaluation makes expressions that read dst itself (dst = −dst, dst += u) safe.
template <class Expr>
void parallel_assign(Coords& dst, const Expr& expr) {
  for_each_atom(static_cast<int>(dst.cols()), [&](int i) { dst.col(i) = expr.col(i); });
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
