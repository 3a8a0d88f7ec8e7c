// Reaction-field pair kernels (formulas and conventions: reaction_field.hpp), as templates on the
// number type: double, or SimdDouble (simd/simd-inl.h), and as a pair form of the pair loop
// (pair_form-inl.h). A Highway per-target header: see simd/simd-inl.h.
#if defined(VIMD_FORCEFIELDS_NONBONDED_REACTION_FIELD_INL_H_) == defined(HWY_TARGET_TOGGLE)
#ifdef VIMD_FORCEFIELDS_NONBONDED_REACTION_FIELD_INL_H_
#undef VIMD_FORCEFIELDS_NONBONDED_REACTION_FIELD_INL_H_
#else
#define VIMD_FORCEFIELDS_NONBONDED_REACTION_FIELD_INL_H_
#endif

#include <cmath>
#include <tuple>

#include "forcefields/nonbonded/reaction_field.hpp"
#include "simd/simd-inl.h"
#include "forcefields/nonbonded/pair_form-inl.h"
#include "forcefields/nonbonded/switch_function-inl.h"

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

// The i atoms' charges, times f/eps_r, per vector of rows.
template <class Real>
struct ReactionFieldHalf {
  SimdVec<Real> q[PairLayout<Real>::kRowVectors];
  HWY_INLINE void load(const PairViewOf<Real>& d, int ib) {
    const ReactionField& rf = std::get<ReactionField>(d.forms);
    Real charges[NeighborList::kHalfSize];
    for (int ii = 0; ii < NeighborList::kHalfSize; ++ii)
      charges[ii] = static_cast<Real>(rf.prefactor * d.charge[ib + ii]);
    for (int r = 0; r < PairLayout<Real>::kRowVectors; ++r) q[r] = broadcast_rows(charges, r * PairLayout<Real>::kRows);
  }
  static constexpr bool active(int) { return true; }
};

template <CoulombModifier C>
struct PairForm<ReactionField, C> {
  using Constants = ReactionField;
  static constexpr CoulombModifier kVariant = C;
  template <class Real>
  using Half = ReactionFieldHalf<Real>;
  template <class Real>
  static HWY_INLINE void energy_force(const PairViewOf<Real>& d, const Half<Real>& hi, int ii, const JBlock<Real>& j,
                                      const PairDistance<Real>& p, SimdVec<Real>& v, SimdVec<Real>& g) {
    rf_energy_force<C>(std::get<ReactionField>(d.forms), hi.q[ii / PairLayout<Real>::kRows] * j.charge, p.rinv, p.r2, v,
                       g);
  }
  template <class Real>
  static HWY_INLINE void add_energy_force(const PairViewOf<Real>& d, const Half<Real>& hi, int ii,
                                          const JBlock<Real>& j, const PairDistance<Real>& p, SimdVec<Real>& v,
                                          SimdVec<Real>& g) {
    rf_add_energy_force<C>(std::get<ReactionField>(d.forms), hi.q[ii / PairLayout<Real>::kRows] * j.charge, p.rinv,
                           p.r2, v, g);
  }
  template <class Real>
  static HWY_INLINE void hessian(const PairViewOf<Real>& d, const Half<Real>& hi, int ii, const JBlock<Real>& j,
                                 const PairDistance<Real>& p, SimdVec<Real>& a, SimdVec<Real>& b) {
    rf_hessian<C>(std::get<ReactionField>(d.forms), hi.q[ii / PairLayout<Real>::kRows] * j.charge, p.rinv, p.r2, a, b);
  }
};

}  // namespace HWY_NAMESPACE
}  // namespace vimd
HWY_AFTER_NAMESPACE();

#endif  // VIMD_FORCEFIELDS_NONBONDED_REACTION_FIELD_INL_H_
