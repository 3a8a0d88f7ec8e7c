// The pair loop's side of a pair form (pair_form.hpp), for the SIMD target being compiled: what it
// loads for the forms, and how it calls them. A Highway per-target header: see simd/simd-inl.h.
//
// A form's kernels (<form>_kernels.h, included by pair_forms-inl.h) specialise
// PairForm<Constants, variant> for each of its variants with, as templates on the number type T
// (a vector of the pair loop's pairs, or double):
//   energy_force(constants, parameters, distance, v, g): the energy φ and g = −φ'(r)/r (the force
//     on i is g d, d = r_i − r_j);
//   hessian(constants, parameters, distance, a, b): a = φ'/r and b = (φ'' − φ'/r)/r², the pair's
//     Hessian block being a I + b d dᵀ;
//   optionally add_energy_force(..., v, g): as energy_force, its g added to g (where a fused
//     multiply-add makes that cheaper than a separate sum).
// parameters is PairParametersOf<Constants::kParameters, T>, which the loop loads per pair
// (PairRows below); distance is PairDistance<T>. Everything is inlined into the pair loop: no
// branch on the variant or the form inside it.
#if defined(VIMD_FORCEFIELDS_NONBONDED_PAIR_FORM_INL_H_) == defined(HWY_TARGET_TOGGLE)
#ifdef VIMD_FORCEFIELDS_NONBONDED_PAIR_FORM_INL_H_
#undef VIMD_FORCEFIELDS_NONBONDED_PAIR_FORM_INL_H_
#else
#define VIMD_FORCEFIELDS_NONBONDED_PAIR_FORM_INL_H_
#endif

#include "forcefields/nonbonded/nonbonded_kernels.hpp"
#include "forcefields/nonbonded/pair_form.hpp"
#include "forcefields/nonbonded/pair_layout-inl.h"
#include "simd/simd-inl.h"

HWY_BEFORE_NAMESPACE();
namespace vimd {
namespace HWY_NAMESPACE {

template <class Constants, auto kVariant>
struct PairForm;

// The constants and the variant of a form's kernels (PairForm<Constants, variant>).
template <class Form>
struct FormOf;
template <class C, auto V>
struct FormOf<PairForm<C, V>> {
  using Constants = C;
  static constexpr auto kVariant = V;
};
template <class Form>
using ConstantsOf = typename FormOf<Form>::Constants;

// Row r of the vector: rows[ii + r][jb ..], e.g. a row of a pair-parameter table.
template <class Real>
HWY_INLINE SimdVec<Real> load_rows(const Real* const* rows, int ii, int jb) {
  using L = PairLayout<Real>;
  if constexpr (L::kRows == 1) {
    return simd_load(rows[ii] + jb);
  } else {
    const hn::Half<typename L::Tag> half;
    return {Combine(typename L::Tag(), hn::LoadU(half, rows[ii + 1] + jb), hn::LoadU(half, rows[ii] + jb))};
  }
}
// p[0 .. kJLanes) += the sum over the rows of x.
template <class Real>
HWY_INLINE void add_j(Real* p, SimdVec<Real> x) {
  using L = PairLayout<Real>;
  if constexpr (L::kRows == 1) {
    simd_store(p, simd_load(p) + x);
  } else {
    const hn::Half<typename L::Tag> half;
    const auto sum = hn::Add(LowerHalf(half, x.v), UpperHalf(half, x.v));
    hn::StoreU(hn::Add(hn::LoadU(half, p), sum), half, p);
  }
}
// p[ii + r] += the sum of row r of x.
template <class Real>
HWY_INLINE void add_row_sums(Real* p, int ii, SimdVec<Real> x) {
  using L = PairLayout<Real>;
  if constexpr (L::kRows == 1) {
    p[ii] += static_cast<Real>(simd_sum(x));
  } else {
    const hn::Half<typename L::Tag> half;
    p[ii] += hn::GetLane(hn::SumOfLanes(half, LowerHalf(half, x.v)));
    p[ii + 1] += hn::GetLane(hn::SumOfLanes(half, UpperHalf(half, x.v)));
  }
}

// The j atoms of a vector: its first slot, and their charges, loaded once for all rows of a list
// entry.
template <class Real>
struct JBlock {
  int slot;
  SimdVec<Real> charge;
};

// What the loop holds of an i-half for the parameters of kind K: loaded once per half by
// load(view, form constants, first slot); active(ii): whether the rows of a vector from row ii on
// have the form at all (false: its terms would be exact zeros, and are skipped); at(ii, j): the
// parameters of those rows with the j atoms of j.
template <PairParameters K, class Real>
struct PairRows;

// qq = (prefactor q_i) q_j, the form's prefactor (f/ε_r) taken into the i atoms' charges once.
template <class Real>
struct PairRows<PairParameters::charge_product, Real> {
  using L = PairLayout<Real>;
  SimdVec<Real> q[L::kRowVectors];
  template <class FormSet, class Constants>
  HWY_INLINE void load(const PairViewOf<Real, FormSet>& d, const Constants& form, int ib) {
    Real charges[kH];
    for (int ii = 0; ii < kH; ++ii) charges[ii] = static_cast<Real>(form.prefactor * d.charge[ib + ii]);
    for (int r = 0; r < L::kRowVectors; ++r) q[r] = broadcast_rows(charges, r * L::kRows);
  }
  static constexpr bool active(int) { return true; }
  HWY_INLINE ChargeProduct<SimdVec<Real>> at(int ii, const JBlock<Real>& j) const { return {q[ii / L::kRows] * j.charge}; }
};

// c6 and c12 from the i atoms' rows of the parameter table (PairViewOf::lj). Rows whose atom has no
// LJ with any type (water's hydrogens: 2 of 3 rows) are not active.
template <class Real>
struct PairRows<PairParameters::lennard_jones, Real> {
  const Real* row[kH];
  bool lj[kH];
  template <class FormSet, class Constants>
  HWY_INLINE void load(const PairViewOf<Real, FormSet>& d, const Constants&, int ib) {
    for (int ii = 0; ii < kH; ++ii) {
      row[ii] = d.lj + lj_index(d.type[ib + ii], 0, d.n_slots);
      lj[ii] = d.type_has_lj[d.type[ib + ii]] != 0;
    }
  }
  HWY_INLINE bool active(int ii) const {
    bool any = false;
    for (int r = 0; r < PairLayout<Real>::kRows; ++r) any |= lj[ii + r];
    return any;
  }
  HWY_INLINE LennardJonesPair<SimdVec<Real>> at(int ii, const JBlock<Real>& j) const {
    const int at = static_cast<int>(lj_index(0, j.slot / kC, 0)) + j.slot % kC;
    return {load_rows(row, ii, at), load_rows(row, ii, at + kC)};
  }
};

// The rows form F reads.
template <class F, class Real>
using PairRowsOf = PairRows<ConstantsOf<F>::kParameters, Real>;

}  // namespace HWY_NAMESPACE
}  // namespace vimd
HWY_AFTER_NAMESPACE();

#endif  // VIMD_FORCEFIELDS_NONBONDED_PAIR_FORM_INL_H_
