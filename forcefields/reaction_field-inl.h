// Reaction-field pair kernels (formulas and conventions: reaction_field.hpp), as templates on the
// number type: double, or SimdDouble (simd-inl.h). A Highway per-target header: see simd-inl.h.
#if defined(VIMD_FORCEFIELDS_REACTION_FIELD_INL_H_) == defined(HWY_TARGET_TOGGLE)
#ifdef VIMD_FORCEFIELDS_REACTION_FIELD_INL_H_
#undef VIMD_FORCEFIELDS_REACTION_FIELD_INL_H_
#else
#define VIMD_FORCEFIELDS_REACTION_FIELD_INL_H_
#endif

#include "forcefields/reaction_field.hpp"
#include "forcefields/simd-inl.h"

HWY_BEFORE_NAMESPACE();
namespace vimd {
namespace HWY_NAMESPACE {

template <class T>
inline void rf_energy_force(const ReactionField& rf, T qq, T rinv, T r2, T& v, T& g) {
  v = qq * (rinv + rf.k_rf * r2 - rf.c_rf);
  g = qq * (rinv * rinv * rinv - 2.0 * rf.k_rf);
}

template <class T>
inline void rf_hessian(const ReactionField& rf, T qq, T rinv, T& a, T& b) {
  const T rinv3 = rinv * rinv * rinv;
  a = qq * (2.0 * rf.k_rf - rinv3);
  b = 3.0 * qq * rinv3 * rinv * rinv;
}

}  // namespace HWY_NAMESPACE
}  // namespace vimd
HWY_AFTER_NAMESPACE();

#endif  // VIMD_FORCEFIELDS_REACTION_FIELD_INL_H_
