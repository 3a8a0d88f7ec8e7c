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
// The evaluation (switch_function-inl.h) is templated on the number type T (double, or a SIMD
// vector) and uses only + − * / and positive_part, with loops whose trip counts are scalars; the
// coefficients are set up once, in switch_function.cpp.
#include <array>


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

}  // namespace vimd
