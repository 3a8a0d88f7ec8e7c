// The one SIMD layer (Google Highway): a native vector of doubles as a number type, so that the
// functional forms (lennard_jones-inl.h, reaction_field-inl.h) are written once, as templates on
// the number type, and instantiated for double (reference sums, tests) and for SimdDouble (the
// pair loops of nonbonded_kernels.cpp). Its width is the target's: 8 lanes on AVX-512, 4 on AVX2,
// 2 on SSE4. No intrinsics outside this file; Highway picks the target at run time.
//
// Highway's per-target header: included once per compiled target (foreach_target.h re-includes
// the kernel file), so it has a toggle guard instead of #pragma once, and everything lives in
// vimd::HWY_NAMESPACE, the target's own namespace.
#if defined(VIMD_FORCEFIELDS_SIMD_INL_H_) == defined(HWY_TARGET_TOGGLE)
#ifdef VIMD_FORCEFIELDS_SIMD_INL_H_
#undef VIMD_FORCEFIELDS_SIMD_INL_H_
#else
#define VIMD_FORCEFIELDS_SIMD_INL_H_
#endif

#include <cstdint>

#include "hwy/highway.h"

HWY_BEFORE_NAMESPACE();
namespace vimd {
namespace HWY_NAMESPACE {

namespace hn = hwy::HWY_NAMESPACE;
using SimdTag = hn::ScalableTag<double>;
using SimdMask = hn::Mask<SimdTag>;

// Arithmetic with doubles on either side, as the scalar kernels write it.
struct SimdDouble {
  hn::Vec<SimdTag> v;
};

HWY_INLINE SimdDouble simd_broadcast(double x) { return {hn::Set(SimdTag(), x)}; }
HWY_INLINE SimdDouble simd_zero() { return {hn::Zero(SimdTag())}; }
HWY_INLINE SimdDouble simd_load(const double* p) { return {hn::LoadU(SimdTag(), p)}; }
HWY_INLINE void simd_store(double* p, SimdDouble x) { hn::StoreU(x.v, SimdTag(), p); }
HWY_INLINE double simd_sum(SimdDouble x) { return hn::GetLane(hn::SumOfLanes(SimdTag(), x.v)); }
// 1/√x to full double precision without the slow square root and division: the single-precision
// estimate (12 bits) and three Newton steps (error 1e-7, 1e-14, then rounding). The division and
// square root units are the pair loops' bottleneck otherwise.
HWY_INLINE SimdDouble simd_rsqrt(SimdDouble x) {
  const hn::Rebind<float, SimdTag> df;
  hn::Vec<SimdTag> y = hn::PromoteTo(SimdTag(), hn::ApproximateReciprocalSqrt(hn::DemoteTo(df, x.v)));
  const hn::Vec<SimdTag> half_x = hn::Mul(x.v, hn::Set(SimdTag(), 0.5)), three_halves = hn::Set(SimdTag(), 1.5);
  for (int k = 0; k < 3; ++k) y = hn::Mul(y, hn::NegMulAdd(half_x, hn::Mul(y, y), three_halves));
  return {y};
}
HWY_INLINE SimdDouble select(SimdMask m, SimdDouble yes, SimdDouble no) { return {hn::IfThenElse(m, yes.v, no.v)}; }
HWY_INLINE SimdDouble keep(SimdMask m, SimdDouble x) { return {hn::IfThenElseZero(m, x.v)}; }
HWY_INLINE SimdMask operator<(SimdDouble a, double b) { return hn::Lt(a.v, hn::Set(SimdTag(), b)); }
HWY_INLINE SimdMask operator&(SimdMask a, SimdMask b) { return hn::And(a, b); }
// Lanes whose bit is set in the low Lanes() bits of `bits`, and back.
HWY_INLINE SimdMask mask_from_bits(unsigned bits) {
  const std::uint8_t byte = static_cast<std::uint8_t>(bits);
  return hn::LoadMaskBits(SimdTag(), &byte);
}
HWY_INLINE unsigned bits_from_mask(SimdMask m) {
  std::uint8_t bytes[8] = {};
  hn::StoreMaskBits(SimdTag(), m, bytes);
  return bytes[0];
}

HWY_INLINE SimdDouble operator+(SimdDouble a, SimdDouble b) { return {hn::Add(a.v, b.v)}; }
HWY_INLINE SimdDouble operator-(SimdDouble a, SimdDouble b) { return {hn::Sub(a.v, b.v)}; }
HWY_INLINE SimdDouble operator*(SimdDouble a, SimdDouble b) { return {hn::Mul(a.v, b.v)}; }
HWY_INLINE SimdDouble operator/(SimdDouble a, SimdDouble b) { return {hn::Div(a.v, b.v)}; }
HWY_INLINE SimdDouble operator-(SimdDouble a) { return {hn::Neg(a.v)}; }
HWY_INLINE SimdDouble operator+(SimdDouble a, double b) { return a + simd_broadcast(b); }
HWY_INLINE SimdDouble operator-(SimdDouble a, double b) { return a - simd_broadcast(b); }
HWY_INLINE SimdDouble operator*(SimdDouble a, double b) { return a * simd_broadcast(b); }
HWY_INLINE SimdDouble operator/(SimdDouble a, double b) { return a / simd_broadcast(b); }
HWY_INLINE SimdDouble operator+(double a, SimdDouble b) { return simd_broadcast(a) + b; }
HWY_INLINE SimdDouble operator-(double a, SimdDouble b) { return simd_broadcast(a) - b; }
HWY_INLINE SimdDouble operator*(double a, SimdDouble b) { return simd_broadcast(a) * b; }
HWY_INLINE SimdDouble operator/(double a, SimdDouble b) { return simd_broadcast(a) / b; }
HWY_INLINE SimdDouble& operator+=(SimdDouble& a, SimdDouble b) { return a = a + b; }
HWY_INLINE SimdDouble& operator-=(SimdDouble& a, SimdDouble b) { return a = a - b; }

// max(x, 0), for scalars and vectors alike (the kernels are templates on the number type).
HWY_INLINE double positive_part(double x) { return x > 0 ? x : 0.0; }
HWY_INLINE SimdDouble positive_part(SimdDouble x) { return {hn::Max(x.v, hn::Zero(SimdTag()))}; }

}  // namespace HWY_NAMESPACE
}  // namespace vimd
HWY_AFTER_NAMESPACE();

#endif  // VIMD_FORCEFIELDS_SIMD_INL_H_
