// Reaction-field pair kernels (formulas and conventions: reaction_field.hpp), as templates on the
// number type: double, or SimdDouble (engine/simd-inl.h). A Highway per-target header: see engine/simd-inl.h.
#if defined(VIMD_FORCEFIELDS_REACTION_FIELD_INL_H_) == defined(HWY_TARGET_TOGGLE)
#ifdef VIMD_FORCEFIELDS_REACTION_FIELD_INL_H_
#undef VIMD_FORCEFIELDS_REACTION_FIELD_INL_H_
#else
#define VIMD_FORCEFIELDS_REACTION_FIELD_INL_H_
#endif

#include <cmath>

#include "forcefields/reaction_field.hpp"
#include "engine/simd-inl.h"
#include "forcefields/switch_function-inl.h"

HWY_BEFORE_NAMESPACE();
namespace vimd {
namespace HWY_NAMESPACE {

// The unswitched pair potential and force factor −φ'/r per unit qq.
template <class T>
inline T rf_unit_potential(const ReactionField& rf, T rinv, T r2) {
  return rinv + rf.k_rf * r2 - rf.c_rf;
}
template <class T>
inline T rf_unit_force(const ReactionField& rf, T rinv) {
  return rinv * rinv * rinv - 2.0 * rf.k_rf;
}

template <CoulombModifier C, class T>
inline void rf_energy_force(const ReactionField& rf, T qq, T rinv, T r2, T& v, T& g) {
  v = qq * rf_unit_potential(rf, rinv, r2);
  g = qq * rf_unit_force(rf, rinv);
  if constexpr (C == CoulombModifier::potential_switch) apply_switch_energy_force(rf.sw, r2 * rinv, rinv, v, g);
}

// The same, its force factor added to g (v set): unswitched, g + qq·(r⁻³ − 2k_rf) is one explicit
// multiply-add, so the force's rounding is the same whether or not the caller also uses v.
template <CoulombModifier C, class T>
inline void rf_add_energy_force(const ReactionField& rf, T qq, T rinv, T r2, T& v, T& g) {
  if constexpr (C == CoulombModifier::potential_switch) {
    T gc;
    rf_energy_force<C>(rf, qq, rinv, r2, v, gc);
    g += gc;
  } else {
    v = qq * rf_unit_potential(rf, rinv, r2);
    g = mul_add(qq, rf_unit_force(rf, rinv), g);
  }
}

template <CoulombModifier C, class T>
inline void rf_hessian(const ReactionField& rf, T qq, T rinv, T r2, T& a, T& b) {
  const T rinv3 = rinv * rinv * rinv;
  a = qq * (2.0 * rf.k_rf - rinv3);
  b = 3.0 * qq * rinv3 * rinv * rinv;
  if constexpr (C == CoulombModifier::potential_switch)
    apply_switch_hessian(rf.sw, qq * rf_unit_potential(rf, rinv, r2), r2 * rinv, rinv, a, b);
}

// Excluded pair inside the cut-off: φ = qq (k_rf r² − c_rf), times S when switched (scalar code:
// few pairs, so the modifier is a run-time test).
inline void rf_excluded_energy_force(const ReactionField& rf, double qq, double r2, double& v, double& g) {
  v = qq * (rf.k_rf * r2 - rf.c_rf);
  g = -2 * qq * rf.k_rf;
  if (rf.modifier == CoulombModifier::potential_switch) {
    const double r = std::sqrt(r2);
    apply_switch_energy_force(rf.sw, r, 1 / r, v, g);
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

}  // namespace HWY_NAMESPACE
}  // namespace vimd
HWY_AFTER_NAMESPACE();

#endif  // VIMD_FORCEFIELDS_REACTION_FIELD_INL_H_
