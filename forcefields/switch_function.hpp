#pragma once
// The potential switch of smoothness k, shared by LJ ("potential-switch" vdw_modifier) and
// Coulomb ("potential-switch" coulomb_modifier): a pair potential U becomes φ = U·S(r − r_switch),
// S(x) = 1 − P(x/w), w = cutoff − r_switch, with P the degree-(2k+1) "smoothstep" polynomial
//   P(t) = t^(k+1) Σ_{n=0..k} (−1)ⁿ C(k+n, n) C(2k+1, k−n) tⁿ,
// the unique polynomial with P(0) = 0, P(1) = 1 and P', ..., P^(k) zero at t = 0 and t = 1.
// Hence φ^(n) for n ≤ k equals U^(n) at r_switch and is 0 at the cut-off: the pair potential is
// C^k across both ends (C^(k+1) at the cut-off when U(rc) = 0, as for reaction field).
// k = 2 is GROMACS's potential-switch, S = 1 − 10t³ + 15t⁴ − 6t⁵.
//
// The evaluation below is templated on the number type T (double, or a SIMD vector) and uses only
// + − * / and positive_part, with loops whose trip counts are scalars; the coefficients are set up
// once, in switch_function.cpp.
#include <array>

#include "engine/simd.hpp"

namespace vimd {

struct SwitchFunction {
  static constexpr int kMinSmoothness = 2, kMaxSmoothness = 6;
  int smoothness = 2;  // k
  double r_switch = 0;
  // With x = r − r_switch ≥ 0: S = 1 + x^(k+1) Σ_i value[i] xⁱ, S' = x^k Σ_i slope[i] xⁱ,
  // S'' = x^(k−1) Σ_i curvature[i] xⁱ, i = 0..k.
  std::array<double, kMaxSmoothness + 1> value{}, slope{}, curvature{};
};

// Throws InputError (naming `what`, e.g. "vdw_switch") unless 0 ≤ r_switch < cutoff and
// kMinSmoothness ≤ smoothness ≤ kMaxSmoothness.
SwitchFunction make_switch_function(double r_switch, double cutoff, int smoothness, const char* what);

namespace switch_detail {
// Σ_{i=0..degree} c[i] xⁱ by Horner, degree ≥ 1 (T is never built from a double alone).
template <class T>
inline T polynomial(const double* c, int degree, T x) {
  T p = x * c[degree] + c[degree - 1];
  for (int i = degree - 2; i >= 0; --i) p = p * x + c[i];
  return p;
}
// xⁿ, n ≥ 1.
template <class T>
inline T power(T x, int n) {
  T p = x;
  for (int i = 1; i < n; ++i) p = p * x;
  return p;
}
}  // namespace switch_detail

// φ = U·S from U and g = −U'/r (on input) to φ and g = −φ'/r (on output); r ≤ cutoff.
template <class T>
inline void apply_switch_energy_force(const SwitchFunction& sw, T r, T rinv, T& v, T& g) {
  const int k = sw.smoothness;
  const T x = positive_part(r - sw.r_switch);
  const T xk = switch_detail::power(x, k);
  const T s = 1.0 + switch_detail::polynomial(sw.value.data(), k, x) * xk * x;
  const T ds = switch_detail::polynomial(sw.slope.data(), k, x) * xk;
  g = g * s - v * ds * rinv;
  v = v * s;
}

// The Hessian coefficients of φ = U·S from those of U (a = U'/r, b = (U'' − U'/r)/r², in place)
// and U itself: φ' = U'S + US', φ'' = U''S + 2U'S' + US''.
template <class T>
inline void apply_switch_hessian(const SwitchFunction& sw, T u, T r, T rinv, T& a, T& b) {
  const int k = sw.smoothness;
  const T x = positive_part(r - sw.r_switch);
  const T xk1 = switch_detail::power(x, k - 1);
  const T xk = xk1 * x;
  const T s = 1.0 + switch_detail::polynomial(sw.value.data(), k, x) * xk * x;
  const T ds = switch_detail::polynomial(sw.slope.data(), k, x) * xk;
  const T dds = switch_detail::polynomial(sw.curvature.data(), k, x) * xk1;
  b = b * s + (2.0 * a * r * ds + u * dds - u * ds * rinv) * rinv * rinv;
  a = a * s + u * ds * rinv;
}

}  // namespace vimd
