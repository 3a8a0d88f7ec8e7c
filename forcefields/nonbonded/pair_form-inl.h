// The kernel side of a nonbonded pair form (pair_form.hpp), for the SIMD target being compiled.
// A Highway per-target header: see simd/simd-inl.h.
//
// A form's -inl.h specialises PairForm<Constants, variant> for each of its variants with
//   using Constants; static constexpr auto kVariant;
//   template <class Real> struct Half: what the form reads of the i atoms of a half-cluster,
//     loaded once per half by load(view, first slot); active(ii): whether the rows of a vector
//     from row ii on (PairLayout) have the form at all (false: its terms are exact zeros and are
//     skipped);
//   energy_force(view, half, ii, j, distance, v, g): per pair of the rows from i atom ii with the
//     j atoms of JBlock j (slots j.slot..), the energy φ and g = −φ'(r)/r (the force on i is g d,
//     d = r_i − r_j); per-row values come from load_rows and broadcast_rows (once per half where
//     they can), per-j values from the JBlock or load_j;
//   hessian(view, half, ii, j, distance, a, b): a = φ'/r and b = (φ'' − φ'/r)/r², the pair's
//     Hessian block being a I + b d dᵀ;
//   optionally add_energy_force(..., v, g): as energy_force, its g added to g (when a fused
//     multiply-add makes that cheaper than a separate sum).
// All are templates on Real (double or float) with V = SimdVec<Real>, inlined into the pair
// loop: no branch on the variant or the form inside it.
#if defined(VIMD_FORCEFIELDS_NONBONDED_PAIR_FORM_INL_H_) == defined(HWY_TARGET_TOGGLE)
#ifdef VIMD_FORCEFIELDS_NONBONDED_PAIR_FORM_INL_H_
#undef VIMD_FORCEFIELDS_NONBONDED_PAIR_FORM_INL_H_
#else
#define VIMD_FORCEFIELDS_NONBONDED_PAIR_FORM_INL_H_
#endif

#include "forcefields/nonbonded/pair_layout-inl.h"
#include "simd/simd-inl.h"
#include "forcefields/nonbonded/nonbonded_kernels.hpp"

HWY_BEFORE_NAMESPACE();
namespace vimd {
namespace HWY_NAMESPACE {

template <class Constants, auto kVariant>
struct PairForm;

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

// The j atoms of a vector: its first slot, and what every form of the charges reads of them, loaded
// once for all rows of a list entry.
template <class Real>
struct JBlock {
  int slot;
  SimdVec<Real> charge;
};

// The distance of a pair, in the forms' terms. Lanes that do not interact carry r2 = 1.
template <class Real>
struct PairDistance {
  SimdVec<Real> r2, rinv, rinv2;
};

}  // namespace HWY_NAMESPACE
}  // namespace vimd
HWY_AFTER_NAMESPACE();

#endif  // VIMD_FORCEFIELDS_NONBONDED_PAIR_FORM_INL_H_
