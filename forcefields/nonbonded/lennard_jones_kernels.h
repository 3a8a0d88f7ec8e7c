// Lennard-Jones as a pair form of the pair loop (formulas, modifiers and constants:
// lennard_jones.hpp), on any number type T: a SIMD vector of pairs in the loop, double elsewhere.
// Included by pair_forms-inl.h inside its per-target namespace, once per SIMD target.
template <VdwModifier M>
struct PairForm<LjConstants, M> {
  template <class T>
  static HWY_INLINE void energy_force(const LjConstants& k, const LennardJonesPair<T>& pair, const PairDistance<T>& p,
                                      T& v, T& g) {
    const T rinv6 = p.rinv2 * p.rinv2 * p.rinv2;
    const T rep = pair.c12 * rinv6 * rinv6;  // c12 r⁻¹²
    const T dis = pair.c6 * rinv6;           // c6 r⁻⁶
    if constexpr (M == VdwModifier::none || M == VdwModifier::potential_shift) {
      v = rep - dis + (pair.c12 * k.shift12 - pair.c6 * k.shift6);
      g = (12.0 * rep - 6.0 * dis) * p.rinv2;
    } else if constexpr (M == VdwModifier::force_switch) {
      const T r = p.r2 * p.rinv;
      const T x = positive_part(r - k.r_switch);
      const T x2 = x * x, x3 = x2 * x;
      const T rinv = p.rinv2 * r;
      v = rep - dis + pair.c12 * (k.shift12 - (k.a12 / 3 + k.b12 / 4.0 * x) * x3) -
          pair.c6 * (k.shift6 - (k.a6 / 3 + k.b6 / 4.0 * x) * x3);
      g = (12.0 * rep - 6.0 * dis) * p.rinv2 +
          (pair.c12 * (k.a12 + k.b12 * x) - pair.c6 * (k.a6 + k.b6 * x)) * x2 * rinv;
    } else {  // potential_switch
      const T r = p.r2 * p.rinv;
      v = rep - dis;
      g = (12.0 * rep - 6.0 * dis) * p.rinv2;
      apply_switch_energy_force(k.sw, r, p.rinv2 * r, v, g);
    }
  }

  template <class T>
  static HWY_INLINE void hessian(const LjConstants& k, const LennardJonesPair<T>& pair, const PairDistance<T>& p, T& a,
                                 T& b) {
    const T rinv6 = p.rinv2 * p.rinv2 * p.rinv2;
    const T rep = pair.c12 * rinv6 * rinv6;
    const T dis = pair.c6 * rinv6;
    if constexpr (M == VdwModifier::none || M == VdwModifier::potential_shift) {
      a = (6.0 * dis - 12.0 * rep) * p.rinv2;
      b = (168.0 * rep - 48.0 * dis) * p.rinv2 * p.rinv2;
    } else if constexpr (M == VdwModifier::force_switch) {
      // Per power n: φ_n'/r = −n r^-(n+2) − (A x² + B x³)/r;
      // (φ_n'' − φ_n'/r)/r² = [n(n+2) r^-(n+2) − 2A x − 3B x² + (A x² + B x³)/r] / r².
      const T r = p.r2 * p.rinv;
      const T x = positive_part(r - k.r_switch);
      const T x2 = x * x;
      const T rinv = p.rinv2 * r;
      const T poly12 = (k.a12 + k.b12 * x) * x2, poly6 = (k.a6 + k.b6 * x) * x2;
      a = (6.0 * dis - 12.0 * rep) * p.rinv2 - (pair.c12 * poly12 - pair.c6 * poly6) * rinv;
      b = ((168.0 * rep - 48.0 * dis) * p.rinv2 - pair.c12 * ((2.0 * k.a12 + 3.0 * k.b12 * x) * x - poly12 * rinv) +
           pair.c6 * ((2.0 * k.a6 + 3.0 * k.b6 * x) * x - poly6 * rinv)) *
          p.rinv2;
    } else {  // potential_switch
      const T r = p.r2 * p.rinv;
      a = (6.0 * dis - 12.0 * rep) * p.rinv2;
      b = (168.0 * rep - 48.0 * dis) * p.rinv2 * p.rinv2;
      apply_switch_hessian(k.sw, rep - dis, r, p.rinv2 * r, a, b);
    }
  }
};
