// Lennard-Jones pair kernels (formulas and conventions: lennard_jones.hpp), as templates on the
// number type: double, or SimdDouble (simd/simd-inl.h), and as a pair form of the pair loop
// (pair_form-inl.h). A Highway per-target header: see simd/simd-inl.h.
#if defined(VIMD_FORCEFIELDS_NONBONDED_LENNARD_JONES_INL_H_) == defined(HWY_TARGET_TOGGLE)
#ifdef VIMD_FORCEFIELDS_NONBONDED_LENNARD_JONES_INL_H_
#undef VIMD_FORCEFIELDS_NONBONDED_LENNARD_JONES_INL_H_
#else
#define VIMD_FORCEFIELDS_NONBONDED_LENNARD_JONES_INL_H_
#endif

#include <tuple>

#include "forcefields/nonbonded/lennard_jones.hpp"
#include "simd/simd-inl.h"
#include "forcefields/nonbonded/pair_form-inl.h"
#include "forcefields/nonbonded/switch_function-inl.h"

HWY_BEFORE_NAMESPACE();
namespace vimd {
namespace HWY_NAMESPACE {

template <VdwModifier M, class T>
inline void lj_energy_force(const LjConstants& k, T c6, T c12, T rinv2, T r, T& v, T& g) {
  const T rinv6 = rinv2 * rinv2 * rinv2;
  const T rep = c12 * rinv6 * rinv6;  // c12 r⁻¹²
  const T dis = c6 * rinv6;           // c6 r⁻⁶
  if constexpr (M == VdwModifier::none || M == VdwModifier::potential_shift) {
    v = rep - dis + (c12 * k.shift12 - c6 * k.shift6);
    g = (12.0 * rep - 6.0 * dis) * rinv2;
  } else if constexpr (M == VdwModifier::force_switch) {
    const T x = positive_part(r - k.r_switch);
    const T x2 = x * x, x3 = x2 * x;
    const T rinv = rinv2 * r;
    v = rep - dis + c12 * (k.shift12 - (k.a12 / 3 + k.b12 / 4.0 * x) * x3) -
        c6 * (k.shift6 - (k.a6 / 3 + k.b6 / 4.0 * x) * x3);
    g = (12.0 * rep - 6.0 * dis) * rinv2 + (c12 * (k.a12 + k.b12 * x) - c6 * (k.a6 + k.b6 * x)) * x2 * rinv;
  } else {  // potential_switch
    v = rep - dis;
    g = (12.0 * rep - 6.0 * dis) * rinv2;
    apply_switch_energy_force(k.sw, r, rinv2 * r, v, g);
  }
}

template <VdwModifier M, class T>
inline void lj_hessian(const LjConstants& k, T c6, T c12, T rinv2, T r, T& a, T& b) {
  const T rinv6 = rinv2 * rinv2 * rinv2;
  const T rep = c12 * rinv6 * rinv6;
  const T dis = c6 * rinv6;
  if constexpr (M == VdwModifier::none || M == VdwModifier::potential_shift) {
    a = (6.0 * dis - 12.0 * rep) * rinv2;
    b = (168.0 * rep - 48.0 * dis) * rinv2 * rinv2;
  } else if constexpr (M == VdwModifier::force_switch) {
    // Per power p: φ_p'/r = −p r^-(p+2) − (A x² + B x³)/r;
    // (φ_p'' − φ_p'/r)/r² = [p(p+2) r^-(p+2) − 2A x − 3B x² + (A x² + B x³)/r] / r².
    const T x = positive_part(r - k.r_switch);
    const T x2 = x * x;
    const T rinv = rinv2 * r;
    const T poly12 = (k.a12 + k.b12 * x) * x2, poly6 = (k.a6 + k.b6 * x) * x2;
    a = (6.0 * dis - 12.0 * rep) * rinv2 - (c12 * poly12 - c6 * poly6) * rinv;
    b = ((168.0 * rep - 48.0 * dis) * rinv2 - c12 * ((2.0 * k.a12 + 3.0 * k.b12 * x) * x - poly12 * rinv) +
         c6 * ((2.0 * k.a6 + 3.0 * k.b6 * x) * x - poly6 * rinv)) *
        rinv2;
  } else {  // potential_switch
    a = (6.0 * dis - 12.0 * rep) * rinv2;
    b = (168.0 * rep - 48.0 * dis) * rinv2 * rinv2;
    apply_switch_hessian(k.sw, rep - dis, r, rinv2 * r, a, b);
  }
}

// The i atoms' rows of the parameter table (PairViewOf::lj). Rows whose atom has no LJ with any
// type (water's hydrogens: 2 of 3 rows) skip the LJ terms: they would add exact zeros.
template <class Real>
struct LjHalf {
  const Real* row[NeighborList::kHalfSize];
  bool lj[NeighborList::kHalfSize];
  HWY_INLINE void load(const PairViewOf<Real>& d, int ib) {
    for (int ii = 0; ii < NeighborList::kHalfSize; ++ii) {
      row[ii] = d.lj + lj_index(d.type[ib + ii], 0, d.n_slots);
      lj[ii] = d.type_has_lj[d.type[ib + ii]] != 0;
    }
  }
  HWY_INLINE bool active(int ii) const {
    bool any = false;
    for (int r = 0; r < PairLayout<Real>::kRows; ++r) any |= lj[ii + r];
    return any;
  }
  // c6 and c12 of the rows from ii with the j atoms from slot jb on.
  HWY_INLINE void parameters(int ii, int jb, SimdVec<Real>& c6, SimdVec<Real>& c12) const {
    constexpr int kC = NeighborList::kClusterSize;
    const int at = static_cast<int>(lj_index(0, jb / kC, 0)) + jb % kC;
    c6 = load_rows(row, ii, at);
    c12 = load_rows(row, ii, at + kC);
  }
};

template <VdwModifier M>
struct PairForm<LjConstants, M> {
  using Constants = LjConstants;
  static constexpr VdwModifier kVariant = M;
  template <class Real>
  using Half = LjHalf<Real>;
  template <class Real>
  static HWY_INLINE void energy_force(const PairViewOf<Real>& d, const Half<Real>& hi, int ii, const JBlock<Real>& j,
                                      const PairDistance<Real>& p, SimdVec<Real>& v, SimdVec<Real>& g) {
    SimdVec<Real> c6, c12;
    hi.parameters(ii, j.slot, c6, c12);
    lj_energy_force<M>(std::get<LjConstants>(d.forms), c6, c12, p.rinv2, p.r2 * p.rinv, v, g);
  }
  template <class Real>
  static HWY_INLINE void hessian(const PairViewOf<Real>& d, const Half<Real>& hi, int ii, const JBlock<Real>& j,
                                 const PairDistance<Real>& p, SimdVec<Real>& a, SimdVec<Real>& b) {
    SimdVec<Real> c6, c12;
    hi.parameters(ii, j.slot, c6, c12);
    lj_hessian<M>(std::get<LjConstants>(d.forms), c6, c12, p.rinv2, p.r2 * p.rinv, a, b);
  }
};

}  // namespace HWY_NAMESPACE
}  // namespace vimd
HWY_AFTER_NAMESPACE();

#endif  // VIMD_FORCEFIELDS_NONBONDED_LENNARD_JONES_INL_H_
