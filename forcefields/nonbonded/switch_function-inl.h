// Evaluation of the potential switch (switch_function.hpp), as templates on the number type:
// double, or SimdDouble (simd/simd-inl.h). A Highway per-target header: see simd/simd-inl.h.
#if defined(VIMD_FORCEFIELDS_NONBONDED_SWITCH_FUNCTION_INL_H_) == defined(HWY_TARGET_TOGGLE)
#ifdef VIMD_FORCEFIELDS_NONBONDED_SWITCH_FUNCTION_INL_H_
#undef VIMD_FORCEFIELDS_NONBONDED_SWITCH_FUNCTION_INL_H_
#else
#define VIMD_FORCEFIELDS_NONBONDED_SWITCH_FUNCTION_INL_H_
#endif

#include "simd/simd-inl.h"
#include "forcefields/nonbonded/switch_function.hpp"

HWY_BEFORE_NAMESPACE();
namespace vimd {
namespace HWY_NAMESPACE {

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

// S and S' at r (r ≤ cutoff).
template <class T>
inline void switch_value_slope(const SwitchFunction& sw, T r, T& s, T& ds) {
  const int k = sw.smoothness;
  const T x = positive_part(r - sw.r_switch);
  const T xk = switch_detail::power(x, k);
  s = 1.0 + switch_detail::polynomial(sw.value.data(), k, x) * xk * x;
  ds = switch_detail::polynomial(sw.slope.data(), k, x) * xk;
}
// φ = U·S from U and g = −U'/r (on input) to φ and g = −φ'/r (on output), given S and S' at r.
template <class T>
inline void apply_switch_factors(T s, T ds, T rinv, T& v, T& g) {
  g = g * s - v * ds * rinv;
  v = v * s;
}
// The same, evaluating S and S' at r ≤ cutoff.
template <class T>
inline void apply_switch_energy_force(const SwitchFunction& sw, T r, T rinv, T& v, T& g) {
  T s, ds;
  switch_value_slope(sw, r, s, ds);
  apply_switch_factors(s, ds, rinv, v, g);
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
}  // namespace HWY_NAMESPACE
}  // namespace vimd
HWY_AFTER_NAMESPACE();

#endif  // VIMD_FORCEFIELDS_NONBONDED_SWITCH_FUNCTION_INL_H_
