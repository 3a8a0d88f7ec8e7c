// Real-space Ewald (PME) as a pair form of the pair loop (formulas and constants: ewald.hpp), on any
// number type T: a SIMD vector of pairs in the loop, double elsewhere. qq includes f/ε_r.
// Included by pair_forms-inl.h inside its per-target namespace, once per SIMD target.

// Horner's rule for C[0] + C[1] x + ... , highest power last.
template <const auto& C, class V>
HWY_INLINE V ewald_polynomial(V x) {
  constexpr std::size_t N = std::size(C);
  V p = splat<C>(N - 1, x);
  for (std::size_t k = N - 1; k-- > 0;) p = mul_add(p, x, splat<C>(k, x));
  return p;
}

// The same as its even and its odd powers, each by Horner's rule in x² (given): two chains of half the
// latency of one, for the double-precision Ewald corrections (the single-precision ones are too short
// to gain from it).
template <const auto& C, class V>
HWY_INLINE V ewald_polynomial_even_odd(V x, V x2) {
  constexpr std::size_t N = std::size(C);
  constexpr std::size_t kTopEven = (N - 1) / 2 * 2, kTopOdd = (N - 2) / 2 * 2 + 1;
  V even = splat<C>(kTopEven, x), odd = splat<C>(kTopOdd, x);
  for (std::size_t k = kTopEven; k >= 2; k -= 2) even = mul_add(even, x2, splat<C>(k - 2, x));
  for (std::size_t k = kTopOdd; k >= 3; k -= 2) odd = mul_add(odd, x2, splat<C>(k - 2, x));
  return mul_add(odd, x, even);
}

// erfc(x) for x ≥ 0 and e^(−x²), lane by lane. W. J. Cody, "Rational Chebyshev approximations for
// the error function", Math. Comp. 23 (1969) 631-637 (the coefficients of Netlib's specfun/calerf),
// relative error ~1e-16 in double; each range only where a lane needs it (the range of most pairs,
// 0.47 ≤ x ≤ 4, always).
template <class V>
HWY_INLINE void ewald_erfc(V x, V& erfc, V& gaussian) {
  static constexpr double kSmallNum[] = {3.20937758913846947e3, 3.77485237685302021e2, 1.13864154151050156e2,
                                         3.16112374387056560e0, 1.85777706184603153e-1};
  static constexpr double kSmallDen[] = {2.84423683343917062e3, 1.28261652607737228e3, 2.44024637934444173e2,
                                         2.36012909523441209e1, 1.0};
  static constexpr double kMidNum[] = {1.23033935479799725e3, 2.05107837782607147e3, 1.71204761263407058e3,
                                       8.81952221241769090e2, 2.98635138197400131e2, 6.61191906371416295e1,
                                       8.88314979438837594e0, 5.64188496988670089e-1, 2.15311535474403846e-8};
  static constexpr double kMidDen[] = {1.23033935480374942e3, 3.43936767414372164e3, 4.36261909014324716e3,
                                       3.29079923573345963e3, 1.62138957456669019e3, 5.37181101862009858e2,
                                       1.17693950891312499e2, 1.57449261107098347e1, 1.0};
  static constexpr double kLargeNum[] = {6.58749161529837803e-4, 1.60837851487422766e-2, 1.25781726111229246e-1,
                                         3.60344899949804439e-1, 3.05326634961232344e-1, 1.63153871373020978e-2};
  static constexpr double kLargeDen[] = {2.33520497626869185e-3, 6.05183413124413191e-2, 5.27905102951428412e-1,
                                         1.87295284992346047e0, 2.56852019228982242e0, 1.0};
  constexpr double kSmall = 0.46875, kLarge = 4.0;
  const V x2 = x * x;
  gaussian = simd_exp(-x2);
  erfc = gaussian * (ewald_polynomial<kMidNum>(x) / ewald_polynomial<kMidDen>(x));
  const auto small = x < kSmall;
  if (any_lane(small)) {
    const V erf = x * ewald_polynomial<kSmallNum>(x2) / ewald_polynomial<kSmallDen>(x2);
    erfc = select(small, 1.0 - erf, erfc);
  }
  const auto large = x > kLarge;
  if (any_lane(large)) {
    const V z = 1.0 / x2;
    const V tail = (0.56418958354775628695 - z * ewald_polynomial<kLargeNum>(z) / ewald_polynomial<kLargeDen>(z)) / x;
    erfc = select(large, gaussian * tail, erfc);
  }
}
HWY_INLINE void ewald_erfc(double x, double& erfc, double& gaussian) {
  erfc = std::erfc(x);
  gaussian = std::exp(-x * x);
}

// erfc(βr)/r and 2β/√π e^(−β²r²), from r² and 1/r.
template <class T>
HWY_INLINE void ewald_parts(const EwaldRealSpace& e, T r2, T rinv, T& erfc_r, T& gauss) {
  T erfc;
  ewald_erfc(e.beta * (r2 * rinv), erfc, gauss);
  erfc_r = erfc * rinv;
  gauss = gauss * (e.beta * M_2_SQRTPI);
}

// The SIMD kernels' forces and energies, as GROMACS's nbnxm kernels compute them: the bare Coulomb
// terms minus corrections that are rational functions of z = (βr)², without exp or erfc:
// erfc(βr)/r = 1/r − β E(z) and (erfc(βr)/r + 2β/√π e^(−z))/r² = 1/r³ − β³ F(z). Fitted for
// βr ≤ EwaldRealSpace::kRationalRange to each precision's rounding of the bare terms, except F in
// double: 7e-12, two degrees shorter, since it is in every force pass (docs/pme.md);
// validation/fit_ewald_corrections.py prints the coefficients and their errors.
template <const auto& kNum, const auto& kDen, const auto& kNumDouble, const auto& kDenDouble, class V>
HWY_INLINE V ewald_rational(V z) {
  if constexpr (std::is_same_v<V, SimdVec<double>>) {
    const V z2 = z * z;
    return ewald_polynomial_even_odd<kNumDouble>(z, z2) / ewald_polynomial_even_odd<kDenDouble>(z, z2);
  }
  return ewald_polynomial<kNum>(z) / ewald_polynomial<kDen>(z);
}
template <class V>
HWY_INLINE V ewald_energy_correction(V z) {
  static constexpr double kNum[] = {1.128379195, 0.1929366645, 0.05613585699, 0.004278845216, 0.0004287928443,
                                    7.461626945e-06};
  static constexpr double kDen[] = {1, 0.5043193748, 0.1178539019, 0.01645765158, 0.001454529627, 7.74300389e-05,
                                    2.971532424e-07};
  static constexpr double kNumDouble[] = {
      1.1283791670955152,     0.20686403575044873,    0.06238933845671546,    0.0058926025224449105,
      0.0007104928185961188,  4.0536731266223132e-05, 2.4987478632378316e-06, 8.0595909868393944e-08,
      2.3478281621438592e-09, 1.8280595143228341e-11, 7.249553750099651e-15};
  static constexpr double kDenDouble[] = {
      1,                      0.51666181172327652,    0.12751171550861382,    0.01986943082596911,
      0.0021734719951191049,  0.00017508848785885992, 1.0552602475971491e-05, 4.6973450853606598e-07,
      1.4582974290734883e-08, 2.6591977890017528e-10, 6.4143222906089195e-13};
  return ewald_rational<kNum, kDen, kNumDouble, kDenDouble>(z);
}
template <class V>
HWY_INLINE V ewald_force_correction(V z) {
  static constexpr double kNum[] = {0.7522546887, -0.01050313425, 0.01915542489, 0.0003318108751, 9.944319324e-05,
                                    7.503196879e-07};
  static constexpr double kDen[] = {1, 0.586053736, 0.1627740619, 0.02812078672, 0.003290181803, 0.0002680790362,
                                    1.440679964e-05};
  static constexpr double kNumDouble[] = {
      0.75225277725330086, -0.018197663807238449, 0.020941632326487537, 0.00018831263821727189,
      0.00013604150944864429, 2.5969080085136513e-06, 2.7681661176351476e-07, 1.8203803094827443e-09,
      -2.1546996911218809e-12};
  static constexpr double kDenDouble[] = {
      1, 0.57580909825137372, 0.1590383549596244, 0.027841116546689082, 0.003431794267830972, 0.00031167035323280287,
      2.111848530049579e-05, 1.0183813925993727e-06, 3.502012830919953e-08};
  return ewald_rational<kNum, kDen, kNumDouble, kDenDouble>(z);
}

template <EwaldModifier M>
struct PairForm<EwaldRealSpace, M> {
  template <class T>
  static HWY_INLINE void energy_force(const EwaldRealSpace& e, const ChargeProduct<T>& pair, const PairDistance<T>& p,
                                      T& v, T& g) {
    const T qq = pair.qq, rinv = p.rinv, r2 = p.r2;
    if constexpr (!std::is_arithmetic_v<T>) {
      if (e.rational_corrections) {
        const T z = r2 * (e.beta * e.beta);
        v = qq * (rinv - e.beta * ewald_energy_correction(z) - e.shift);
        g = qq * (rinv * rinv * rinv - (e.beta * e.beta * e.beta) * ewald_force_correction(z));
        if constexpr (M == EwaldModifier::potential_switch) apply_switch_energy_force(e.sw, r2 * rinv, rinv, v, g);
        return;
      }
    }
    T erfc_r, gauss;
    ewald_parts(e, r2, rinv, erfc_r, gauss);
    v = qq * (erfc_r - e.shift);
    g = qq * (erfc_r + gauss) * (rinv * rinv);
    if constexpr (M == EwaldModifier::potential_switch) apply_switch_energy_force(e.sw, r2 * rinv, rinv, v, g);
  }

  template <class T>
  static HWY_INLINE void hessian(const EwaldRealSpace& e, const ChargeProduct<T>& pair, const PairDistance<T>& p, T& a,
                                 T& b) {
    const T qq = pair.qq, rinv = p.rinv, r2 = p.r2;
    T erfc_r, gauss;
    ewald_parts(e, r2, rinv, erfc_r, gauss);
    const T rinv2 = rinv * rinv;
    const T slope = (erfc_r + gauss) * rinv2;  // −φ'/r per unit qq
    a = -qq * slope;
    b = qq * (3.0 * slope + (2.0 * e.beta * e.beta) * gauss) * rinv2;
    if constexpr (M == EwaldModifier::potential_switch) apply_switch_hessian(e.sw, qq * erfc_r, r2 * rinv, rinv, a, b);
  }
};

// erf(x) and e^(−x²): the library's in double, from Cody's erfc lane by lane.
inline void ewald_erf(double x, double& erf, double& gaussian) {
  erf = std::erf(x);
  gaussian = std::exp(-x * x);
}
template <class V>
HWY_INLINE void ewald_erf(V x, V& erf, V& gaussian) {
  V erfc;
  ewald_erfc(x, erfc, gaussian);
  erf = 1.0 - erfc;
}

// Excluded pair inside the cut-off: φ = −qq erf(βr)/r, taking back what the mesh counts of it.
// Its force factor per unit qq, (G − erf(βr)/r)/r², G = 2β/√π e^(−β²r²); sets erf(βr)/r and G.
// On double or SimdDouble.
template <class T>
inline T ewald_excluded_slope(const EwaldRealSpace& e, T r2, T& erf_r, T& gauss) {
  const T r = simd_sqrt(r2);
  T erf;
  ewald_erf(e.beta * r, erf, gauss);
  erf_r = erf / r;
  gauss = (e.beta * M_2_SQRTPI) * gauss;
  return (gauss - erf_r) / r2;
}
template <class T>
inline void ewald_excluded_energy_force(const EwaldRealSpace& e, T qq, T r2, T& v, T& g) {
  if constexpr (!std::is_arithmetic_v<T>) {
    // From the kernels' corrections (ewald_energy_force): erf(βr)/r = β E(z) and the slope −β³ F(z),
    // without exp, erf or a square root.
    if (e.rational_corrections) {
      const T z = r2 * (e.beta * e.beta);
      v = -(qq * e.beta) * ewald_energy_correction(z);
      g = -(qq * (e.beta * e.beta * e.beta)) * ewald_force_correction(z);
      return;
    }
  }
  T erf_r, gauss;
  g = qq * ewald_excluded_slope(e, r2, erf_r, gauss);
  v = -(qq * erf_r);
}
inline void ewald_excluded_hessian(const EwaldRealSpace& e, double qq, double r2, double& a, double& b) {
  double erf_r, gauss;
  const double slope = ewald_excluded_slope(e, r2, erf_r, gauss);
  a = -qq * slope;
  b = qq * (3 * slope + 2 * e.beta * e.beta * gauss) / r2;
}

// The excluded-pair terms as the pair loop calls them: at distance² r2 < cutoff², for the charge
// product q_i q_j; the energy and force on double or SimdDouble, the Hessian on double.
template <class T>
inline void excluded_energy_force(const EwaldRealSpace& e, T charge_product, T r2, T& v, T& g) {
  ewald_excluded_energy_force(e, e.prefactor * charge_product, r2, v, g);
}
inline void excluded_hessian(const EwaldRealSpace& e, double charge_product, double r2, double& a, double& b) {
  ewald_excluded_hessian(e, e.prefactor * charge_product, r2, a, b);
}
