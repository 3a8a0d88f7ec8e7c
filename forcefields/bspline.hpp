#pragma once
// Cardinal B-splines M_p for particle-mesh interpolation, in GROMACS's convention (pme-order p =
// number of grid points a charge reaches; Essmann et al. 1995 call it n). For a charge at grid
// coordinate u = n·s (s its fractional coordinate), with cell i = ⌊u⌋ and offset d = u − i ∈ [0,1):
//   weight on grid point i + k, k = 0..p−1:  θ_k(d) = M_p(d + p − 1 − k)
// M_1 = 1 on [0,1); M_p(x) = (x M_{p−1}(x) + (p − x) M_{p−1}(x − 1)) / (p − 1), support [0,p].
// Derivatives in d from M_p' (x) = M_{p−1}(x) − M_{p−1}(x − 1), applied twice.
#include <array>

namespace vimd {

constexpr int kMaxSplineOrder = 12;

// Weights θ_k and their first (and second) derivatives in d, for k = 0..order−1.
template <class Real>
struct SplineWeights {
  std::array<Real, kMaxSplineOrder> value, first, second;
};

// w[k] = M_m(d + m − 1 − k) for k < m, from the same at order m − 1 (w[m−1] unset on entry).
template <class Real>
inline void raise_spline_order(Real d, int m, Real* w) {
  const Real inv = Real(1) / Real(m - 1);
  w[m - 1] = inv * d * w[m - 2];
  for (int k = m - 2; k > 0; --k) w[k] = inv * ((d + Real(m - 1 - k)) * w[k - 1] + (Real(1 + k) - d) * w[k]);
  w[0] = inv * (Real(1) - d) * w[0];
}

// θ(d) at order p ≥ 3 (second derivatives only when asked).
template <class Real>
inline void spline_weights(Real d, int p, bool second_derivative, SplineWeights<Real>& out) {
  Real w[kMaxSplineOrder];
  w[0] = 1;
  for (int m = 2; m <= p - 2; ++m) raise_spline_order(d, m, w);
  if (second_derivative) {  // from M_{p−2}: θ''_k = w[k−2] − 2 w[k−1] + w[k] (w zero outside 0..p−3)
    for (int k = 0; k < p; ++k) {
      const Real a = k >= 2 && k - 2 <= p - 3 ? w[k - 2] : Real(0);
      const Real b = k >= 1 && k - 1 <= p - 3 ? w[k - 1] : Real(0);
      const Real c = k <= p - 3 ? w[k] : Real(0);
      out.second[k] = a - 2 * b + c;
    }
  }
  raise_spline_order(d, p - 1, w);
  out.first[0] = -w[0];  // from M_{p−1}: θ'_k = w[k−1] − w[k]
  for (int k = 1; k < p - 1; ++k) out.first[k] = w[k - 1] - w[k];
  out.first[p - 1] = w[p - 2];
  raise_spline_order(d, p, w);
  for (int k = 0; k < p; ++k) out.value[k] = w[k];
}

// M_p at the integers 1..p−1 (M_p(0) = M_p(p) = 0): the interpolation's discrete symbol, whose
// Fourier moduli enter the influence function.
inline std::array<double, kMaxSplineOrder> spline_at_integers(int p) {
  double w[kMaxSplineOrder];
  w[0] = 1;
  for (int m = 2; m <= p; ++m) raise_spline_order(0.0, m, w);
  // At d = 0, w[k] = M_p(p − 1 − k): reverse to M_p(1..p−1).
  std::array<double, kMaxSplineOrder> at{};
  for (int j = 0; j < p - 1; ++j) at[j] = w[p - 2 - j];
  return at;
}

}  // namespace vimd
