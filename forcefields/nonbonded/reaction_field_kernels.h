// Reaction field as a pair form of the pair loop (formulas and constants: reaction_field.hpp), on
// any number type T: a SIMD vector of pairs in the loop, double elsewhere. qq includes f/ε_r.
// Included by pair_forms-inl.h inside its per-target namespace, once per SIMD target.

// The unswitched pair potential and force factor −φ'/r per unit qq.
template <class T>
inline T rf_unit_potential(const ReactionField& rf, T rinv, T r2) {
  return rinv + rf.k_rf * r2 - rf.c_rf;
}
template <class T>
inline T rf_unit_force(const ReactionField& rf, T rinv) {
  return rinv * rinv * rinv - 2.0 * rf.k_rf;
}

template <CoulombModifier C>
struct PairForm<ReactionField, C> {
  template <class T>
  static HWY_INLINE void energy_force(const ReactionField& rf, const ChargeProduct<T>& pair, const PairDistance<T>& p,
                                      T& v, T& g) {
    v = pair.qq * rf_unit_potential(rf, p.rinv, p.r2);
    g = pair.qq * rf_unit_force(rf, p.rinv);
    if constexpr (C == CoulombModifier::potential_switch)
      apply_switch_energy_force(rf.sw, p.r2 * p.rinv, p.rinv, v, g);
  }
  // The same, its force factor added to g (v set): unswitched, g + qq·(r⁻³ − 2k_rf) is one
  // explicit multiply-add, so the force's rounding is the same whether or not v is used.
  template <class T>
  static HWY_INLINE void add_energy_force(const ReactionField& rf, const ChargeProduct<T>& pair,
                                          const PairDistance<T>& p, T& v, T& g) {
    if constexpr (C == CoulombModifier::potential_switch) {
      T gc;
      energy_force(rf, pair, p, v, gc);
      g += gc;
    } else {
      v = pair.qq * rf_unit_potential(rf, p.rinv, p.r2);
      g = mul_add(pair.qq, rf_unit_force(rf, p.rinv), g);
    }
  }
  template <class T>
  static HWY_INLINE void hessian(const ReactionField& rf, const ChargeProduct<T>& pair, const PairDistance<T>& p, T& a,
                                 T& b) {
    const T rinv3 = p.rinv * p.rinv * p.rinv;
    a = pair.qq * (2.0 * rf.k_rf - rinv3);
    b = 3.0 * pair.qq * rinv3 * p.rinv * p.rinv;
    if constexpr (C == CoulombModifier::potential_switch)
      apply_switch_hessian(rf.sw, pair.qq * rf_unit_potential(rf, p.rinv, p.r2), p.r2 * p.rinv, p.rinv, a, b);
  }
};

// Excluded pair inside the cut-off: φ = qq (k_rf r² − c_rf), times S when switched (the modifier
// is a run-time test: the excluded pairs have their own loop); on double or SimdDouble.
template <class T>
inline void rf_excluded_energy_force(const ReactionField& rf, T qq, T r2, T& v, T& g) {
  v = qq * (rf.k_rf * r2 - rf.c_rf);
  g = (-2.0 * rf.k_rf) * qq;
  if (rf.modifier == CoulombModifier::potential_switch) {
    const T r = simd_sqrt(r2);
    apply_switch_energy_force(rf.sw, r, 1.0 / r, v, g);
  }
}
inline void rf_excluded_hessian(const ReactionField& rf, double qq, double r2, double& a, double& b) {
  a = 2 * qq * rf.k_rf;
  b = 0;
  if (rf.modifier == CoulombModifier::potential_switch) {
    const double r = std::sqrt(r2);
    apply_switch_hessian(rf.sw, qq * (rf.k_rf * r2 - rf.c_rf), r, 1 / r, a, b);
  }
}

// The excluded-pair terms as the pair loop calls them: at distance² r2 < cutoff², for the charge
// product q_i q_j; the energy and force on double or SimdDouble, the Hessian on double.
template <class T>
inline void excluded_energy_force(const ReactionField& rf, T charge_product, T r2, T& v, T& g) {
  rf_excluded_energy_force(rf, rf.prefactor * charge_product, r2, v, g);
}
inline void excluded_hessian(const ReactionField& rf, double charge_product, double r2, double& a, double& b) {
  rf_excluded_hessian(rf, rf.prefactor * charge_product, r2, a, b);
}
