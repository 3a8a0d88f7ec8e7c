// The excluded pairs' terms, for the SIMD target being compiled: what the forms with excluded-pair
// terms (pair_form.hpp: kExcludedPairs) still count of the excluded pairs inside the cut-off, as
// templates on the precision of the force buffers. A Highway per-target header: see simd/simd-inl.h.
#if defined(VIMD_FORCEFIELDS_NONBONDED_EXCLUDED_PAIRS_INL_H_) == defined(HWY_TARGET_TOGGLE)
#ifdef VIMD_FORCEFIELDS_NONBONDED_EXCLUDED_PAIRS_INL_H_
#undef VIMD_FORCEFIELDS_NONBONDED_EXCLUDED_PAIRS_INL_H_
#else
#define VIMD_FORCEFIELDS_NONBONDED_EXCLUDED_PAIRS_INL_H_
#endif

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <tuple>
#include <type_traits>

#include "forcefields/nonbonded/nonbonded_kernels.hpp"
#include "forcefields/nonbonded/pair_forms-inl.h"
#include "hwy/highway.h"
#include "simd/simd-inl.h"

HWY_BEFORE_NAMESPACE();
namespace vimd {
namespace HWY_NAMESPACE {
namespace {

// Lane k: values[index_k] in double precision, for the lanes of SimdDouble.
template <class Real>
HWY_INLINE SimdDouble gather_double(const Real* values, hn::Vec<hn::Rebind<std::int32_t, SimdTag>> index) {
  const SimdTag dd;
  if constexpr (std::is_same_v<Real, float>)
    return {hn::PromoteTo(dd, hn::GatherIndex(hn::Rebind<float, SimdTag>(), values, index))};
  else
    return {hn::GatherIndex(dd, values, hn::PromoteTo(hn::Rebind<std::int64_t, SimdTag>(), index))};
}

// ExcludedKernelOf for one form: pairs in vectors of doubles, their forces added one pair at a
// time (an atom is in several pairs of a vector).
template <class Form, class Real>
HWY_INLINE void form_excluded_pairs(const Form& form, const PairViewOf<Real>& d, const NeighborList::ExcludedPair* pairs,
                                    double cutoff2, int p0, int p1, Real* fx, Real* fy, Real* fz, double* energies) {
  using V = SimdDouble;
  using Pair = NeighborList::ExcludedPair;
  static_assert(sizeof(Pair) == 3 * sizeof(std::int32_t), "ExcludedPair: three packed ints");
  constexpr int kMaxLanes = HWY_MAX_BYTES / sizeof(double);
  const hn::Rebind<std::int32_t, SimdTag> di;
  const int lanes = V::lanes();
  const double* shifts = d.shifts[0].data();
  HWY_ALIGN double x[kMaxLanes], y[kMaxLanes], z[kMaxLanes];
  V energy = V::zero();
  for (int p = p0; p < p1; p += lanes) {
    const int n = std::min(lanes, p1 - p);
    const Pair* batch = pairs + p;
    Pair padded[kMaxLanes];
    if (n < lanes) {  // lanes past n repeat the last pair, masked below
      for (int k = 0; k < lanes; ++k) padded[k] = pairs[p + std::min(k, n - 1)];
      batch = padded;
    }
    hn::Vec<decltype(di)> i, j, shift;
    hn::LoadInterleaved3(di, reinterpret_cast<const std::int32_t*>(batch), i, j, shift);
    shift = hn::Mul(shift, hn::Set(di, 3));
    const V dx = gather_double(d.x, i) - gather_double(d.x, j) - gather_double(shifts, shift);
    const V dy = gather_double(d.y, i) - gather_double(d.y, j) - gather_double(shifts + 1, shift);
    const V dz = gather_double(d.z, i) - gather_double(d.z, j) - gather_double(shifts + 2, shift);
    const V r2 = dx * dx + dy * dy + dz * dz;
    const SimdMask inside = mask_from_bits<double>((1u << n) - 1) & (r2 < cutoff2);
    V v, g;
    excluded_energy_force(form, gather_double(d.charge, i) * gather_double(d.charge, j),
                          select(inside, r2, V::broadcast(1.0)), v, g);
    energy += keep(inside, v);
    g = keep(inside, g);
    simd_store(x, g * dx);
    simd_store(y, g * dy);
    simd_store(z, g * dz);
    for (int k = 0; k < n; ++k) {
      const int a = batch[k].i_slot, b = batch[k].j_slot;
      fx[a] += x[k];
      fy[a] += y[k];
      fz[a] += z[k];
      fx[b] -= x[k];
      fy[b] -= y[k];
      fz[b] -= z[k];
    }
  }
  energies[static_cast<int>(Form::kEnergy)] += simd_sum(energy);
}

// ExcludedKernelOf: every present form with excluded pairs (PairFormConstants' I-th onwards).
template <class Real, std::size_t I = 0>
void excluded_pairs(const PairViewOf<Real>& d, const NeighborList::ExcludedPair* pairs, double cutoff2, int p0, int p1,
                    Real* fx, Real* fy, Real* fz, double* energies) {
  if constexpr (I < std::tuple_size_v<PairFormConstants>) {
    using Form = std::tuple_element_t<I, PairFormConstants>;
    if constexpr (kHasExcludedPairs<Form>) {
      const Form& form = std::get<I>(d.forms);
      if (form.present()) form_excluded_pairs(form, d, pairs, cutoff2, p0, p1, fx, fy, fz, energies);
    }
    excluded_pairs<Real, I + 1>(d, pairs, cutoff2, p0, p1, fx, fy, fz, energies);
  }
}

}  // namespace
}  // namespace HWY_NAMESPACE
}  // namespace vimd
HWY_AFTER_NAMESPACE();

#endif  // VIMD_FORCEFIELDS_NONBONDED_EXCLUDED_PAIRS_INL_H_
