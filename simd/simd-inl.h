// The one SIMD layer (Google Highway): a native vector of doubles as a number type, so that the
// functional forms (forcefields/nonbonded/*_kernels.h) are written once, as templates on
// the number type, and instantiated for double (reference sums, tests) and for SimdDouble (the
// pair loops of forcefields/nonbonded/pair_loops-inl.h). Its width is the target's: 8 lanes on
// AVX-512, 4 on AVX2, 2 on SSE4. SimdFloat, the same in single precision (up to 16 lanes), serves
// the mixed-precision kernels and the neighbour search's cluster-pair distances
// (cluster_pair_kernels.cpp). No intrinsics outside this file; Highway picks the target at run
// time (one choice for all kernels: simd::use_target).
//
// Highway's per-target header: included once per compiled target (foreach_target.h re-includes
// the kernel file), so it has a toggle guard instead of #pragma once, and everything lives in
// vimd::HWY_NAMESPACE, the target's own namespace.
#if defined(VIMD_SIMD_SIMD_INL_H_) == defined(HWY_TARGET_TOGGLE)
#ifdef VIMD_SIMD_SIMD_INL_H_
#undef VIMD_SIMD_SIMD_INL_H_
#else
#define VIMD_SIMD_SIMD_INL_H_
#endif

#include <array>
#include <bit>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>

#include "hwy/highway.h"
#include "hwy/contrib/math/math-inl.h"

HWY_BEFORE_NAMESPACE();
namespace vimd {
namespace HWY_NAMESPACE {

namespace hn = hwy::HWY_NAMESPACE;

// Tags of the two arithmetic precisions: doubles at the target's full width, and floats (the
// mixed-precision force kernel) at up to 16 lanes, two rows of 8 j atoms on AVX-512 (the pair
// loop's layout: forcefields/nonbonded/pair_form-inl.h).
template <class Real>
struct SimdTagOf {
  using type = hn::ScalableTag<double>;
};
template <>
struct SimdTagOf<float> {
  using type = hn::CappedTag<float, 16>;
};

// Arithmetic with doubles on either side, as the scalar kernels write it (a double operand is
// rounded to Real).
template <class Real>
struct SimdVec {
  using Tag = typename SimdTagOf<Real>::type;
  hn::Vec<Tag> v;
  static HWY_INLINE SimdVec broadcast(double x) { return {hn::Set(Tag(), static_cast<Real>(x))}; }
  static HWY_INLINE SimdVec zero() { return {hn::Zero(Tag())}; }
  static HWY_INLINE int lanes() { return static_cast<int>(hn::Lanes(Tag())); }
};
template <class Real>
struct SimdMaskOf {
  hn::Mask<typename SimdVec<Real>::Tag> m;
};
using SimdDouble = SimdVec<double>;
using SimdFloat = SimdVec<float>;
using SimdTag = SimdDouble::Tag;
using SimdMask = SimdMaskOf<double>;

// Element k of the compile-time array C (doubles, rounded to the lanes' type) in every lane, as a
// vector of the argument's type (only its type is used): the constants of the pair loops' polynomials
// and Newton steps. Before AVX-512, x86 cannot broadcast a constant inside an arithmetic instruction:
// Set costs a broadcast per use there (the loops have no register left to keep it in), where a whole
// vector in a table is an operand that the FMA reads straight from memory.
template <class Real, const auto& C>
struct SplatTable {
  static constexpr std::size_t kLanes = hn::MaxLanes(typename SimdVec<Real>::Tag());
  alignas(64) static constexpr std::array<std::array<Real, kLanes>, std::size(C)> kRows = [] {
    std::array<std::array<Real, kLanes>, std::size(C)> rows{};
    for (std::size_t k = 0; k < std::size(C); ++k) rows[k].fill(static_cast<Real>(C[k]));
    return rows;
  }();
};
template <const auto& C, class Real>
HWY_INLINE SimdVec<Real> splat(std::size_t k, SimdVec<Real>) {
#if HWY_ARCH_X86 && HWY_TARGET > HWY_AVX3 && HWY_TARGET != HWY_EMU128 && HWY_TARGET != HWY_SCALAR
  // Hidden from the optimiser, which would otherwise turn the load back into a broadcast.
  const Real* rows = SplatTable<Real, C>::kRows[0].data();
  asm("" : "+r"(rows));
  return {hn::Load(typename SimdVec<Real>::Tag(), rows + k * SplatTable<Real, C>::kLanes)};
#else
  return SimdVec<Real>::broadcast(C[k]);
#endif
}

template <class Real>
HWY_INLINE SimdVec<Real> simd_load(const Real* p) {
  return {hn::LoadU(typename SimdVec<Real>::Tag(), p)};
}
template <class Real>
HWY_INLINE void simd_store(Real* p, SimdVec<Real> x) {
  hn::StoreU(x.v, typename SimdVec<Real>::Tag(), p);
}
template <class Real>
HWY_INLINE double simd_sum(SimdVec<Real> x) {
  return static_cast<double>(hn::GetLane(hn::SumOfLanes(typename SimdVec<Real>::Tag(), x.v)));
}
// 1/√x to full double precision without the slow square root and division: a hardware estimate
// refined by steps that raise its relative error to a power. AVX-512 estimates doubles to 14 bits
// and takes two Newton steps (6e-9, then rounding). Other targets take the single-precision estimate
// (12 bits, |e| < 7.4e-4 for e = 1 − x·y²) and one step of the series (1 − e)^(−1/2) = 1 + e/2 +
// 3e²/8 + 5e³/16 + 35e⁴/128 + …, whose first omitted term is below 6e-17: the three Newton steps it
// replaces were a third longer a chain, on the critical path of the pair loops. The division and
// square root units are the pair loops' bottleneck otherwise.
HWY_INLINE SimdDouble simd_rsqrt(SimdDouble x) {
  const SimdTag d;
#if HWY_ARCH_X86 && HWY_TARGET <= HWY_AVX3
  hn::Vec<SimdTag> y{_mm512_rsqrt14_pd(x.v.raw)};
  const hn::Vec<SimdTag> half_x = hn::Mul(x.v, hn::Set(d, 0.5)), three_halves = hn::Set(d, 1.5);
  for (int k = 0; k < 2; ++k) y = hn::Mul(y, hn::NegMulAdd(half_x, hn::Mul(y, y), three_halves));
  return {y};
#else
  const hn::Rebind<float, SimdTag> df;
  hn::Vec<SimdTag> y = hn::PromoteTo(d, hn::ApproximateReciprocalSqrt(hn::DemoteTo(df, x.v)));
#if !HWY_ARCH_X86 || HWY_TARGET == HWY_SCALAR
  // Estimates coarser than x86's 12 bits (the portable bit trick: 2e-3) take a Newton step first.
  y = hn::Mul(y, hn::NegMulAdd(hn::Mul(x.v, hn::Set(d, 0.5)), hn::Mul(y, y), hn::Set(d, 1.5)));
#endif
  static constexpr double kSeries[] = {1.0, 0.5, 3.0 / 8, 5.0 / 16, 35.0 / 128};
  const hn::Vec<SimdTag> e = hn::NegMulAdd(x.v, hn::Mul(y, y), splat<kSeries>(0, x).v);
  hn::Vec<SimdTag> series = hn::MulAdd(e, splat<kSeries>(4, x).v, splat<kSeries>(3, x).v);
  series = hn::MulAdd(series, e, splat<kSeries>(2, x).v);
  series = hn::MulAdd(series, e, splat<kSeries>(1, x).v);
  return {hn::MulAdd(hn::Mul(series, e), y, y)};
#endif
}
// Single precision: the estimate and one Newton step (error ~2e-7, a few float ulp, as GROMACS's
// mixed-precision kernels). The portable SCALAR estimate (the bit trick, error ~2e-3) needs two.
HWY_INLINE SimdFloat simd_rsqrt(SimdFloat x) {
  using Tag = SimdFloat::Tag;
  constexpr int kNewtonSteps = HWY_TARGET == HWY_SCALAR ? 2 : 1;
  hn::Vec<Tag> y = hn::ApproximateReciprocalSqrt(x.v);
  static constexpr double kNewton[] = {0.5, 1.5};
  const hn::Vec<Tag> half_x = hn::Mul(x.v, splat<kNewton>(0, x).v), three_halves = splat<kNewton>(1, x).v;
  for (int k = 0; k < kNewtonSteps; ++k) y = hn::Mul(y, hn::NegMulAdd(half_x, hn::Mul(y, y), three_halves));
  return {y};
}
template <class Real>
HWY_INLINE SimdVec<Real> select(SimdMaskOf<Real> m, SimdVec<Real> yes, SimdVec<Real> no) {
  return {hn::IfThenElse(m.m, yes.v, no.v)};
}
template <class Real>
HWY_INLINE SimdVec<Real> keep(SimdMaskOf<Real> m, SimdVec<Real> x) {
  return {hn::IfThenElseZero(m.m, x.v)};
}
template <class Real>
HWY_INLINE SimdMaskOf<Real> operator<(SimdVec<Real> a, SimdVec<Real> b) {
  return {hn::Lt(a.v, b.v)};
}
template <class Real>
HWY_INLINE SimdMaskOf<Real> operator<(SimdVec<Real> a, double b) {
  return {hn::Lt(a.v, SimdVec<Real>::broadcast(b).v)};
}
template <class Real>
HWY_INLINE SimdMaskOf<Real> operator>(SimdVec<Real> a, double b) {
  return {hn::Gt(a.v, SimdVec<Real>::broadcast(b).v)};
}
// Whether any lane is set: for work that only some vectors need (a branch on the whole vector,
// each lane's result being the same either way).
template <class Real>
HWY_INLINE bool any_lane(SimdMaskOf<Real> m) {
  return !hn::AllFalse(typename SimdVec<Real>::Tag(), m.m);
}
template <class Real>
HWY_INLINE SimdMaskOf<Real> operator&(SimdMaskOf<Real> a, SimdMaskOf<Real> b) {
  return {hn::And(a.m, b.m)};
}
// Lanes whose bit is set in the low lanes() bits of `bits` (at most 16 lanes), and back.
// Highway's bit arrays are little-endian, as are the targets: the bits are copied as one 16-bit
// word each way, which compiles to a single move between a mask and a general register (the pair
// and pruning loops do this per vector).
static_assert(std::endian::native == std::endian::little);
template <class Real>
HWY_INLINE SimdMaskOf<Real> mask_from_bits(unsigned bits) {
  std::uint8_t bytes[8] = {};
  const auto low = static_cast<std::uint16_t>(bits);
  std::memcpy(bytes, &low, sizeof low);
  return {hn::LoadMaskBits(typename SimdVec<Real>::Tag(), bytes)};
}
template <class Real>
HWY_INLINE unsigned bits_from_mask(SimdMaskOf<Real> m) {
  std::uint8_t bytes[8] = {};
  hn::StoreMaskBits(typename SimdVec<Real>::Tag(), m.m, bytes);
  std::uint16_t bits;
  std::memcpy(&bits, bytes, sizeof bits);
  return bits;
}

template <class Real>
HWY_INLINE SimdVec<Real> operator+(SimdVec<Real> a, SimdVec<Real> b) {
  return {hn::Add(a.v, b.v)};
}
template <class Real>
HWY_INLINE SimdVec<Real> operator-(SimdVec<Real> a, SimdVec<Real> b) {
  return {hn::Sub(a.v, b.v)};
}
template <class Real>
HWY_INLINE SimdVec<Real> operator*(SimdVec<Real> a, SimdVec<Real> b) {
  return {hn::Mul(a.v, b.v)};
}
template <class Real>
HWY_INLINE SimdVec<Real> operator/(SimdVec<Real> a, SimdVec<Real> b) {
  return {hn::Div(a.v, b.v)};
}
template <class Real>
HWY_INLINE SimdVec<Real> operator-(SimdVec<Real> a) {
  return {hn::Neg(a.v)};
}
template <class Real>
HWY_INLINE SimdVec<Real> operator+(SimdVec<Real> a, double b) {
  return a + SimdVec<Real>::broadcast(b);
}
template <class Real>
HWY_INLINE SimdVec<Real> operator-(SimdVec<Real> a, double b) {
  return a - SimdVec<Real>::broadcast(b);
}
template <class Real>
HWY_INLINE SimdVec<Real> operator*(SimdVec<Real> a, double b) {
  return a * SimdVec<Real>::broadcast(b);
}
template <class Real>
HWY_INLINE SimdVec<Real> operator/(SimdVec<Real> a, double b) {
  return a / SimdVec<Real>::broadcast(b);
}
template <class Real>
HWY_INLINE SimdVec<Real> operator+(double a, SimdVec<Real> b) {
  return SimdVec<Real>::broadcast(a) + b;
}
template <class Real>
HWY_INLINE SimdVec<Real> operator-(double a, SimdVec<Real> b) {
  return SimdVec<Real>::broadcast(a) - b;
}
template <class Real>
HWY_INLINE SimdVec<Real> operator*(double a, SimdVec<Real> b) {
  return SimdVec<Real>::broadcast(a) * b;
}
template <class Real>
HWY_INLINE SimdVec<Real> operator/(double a, SimdVec<Real> b) {
  return SimdVec<Real>::broadcast(a) / b;
}
template <class Real>
HWY_INLINE SimdVec<Real>& operator+=(SimdVec<Real>& a, SimdVec<Real> b) {
  return a = a + b;
}
template <class Real>
HWY_INLINE SimdVec<Real>& operator-=(SimdVec<Real>& a, SimdVec<Real> b) {
  return a = a - b;
}

template <class Real>
HWY_INLINE SimdVec<Real> simd_min(SimdVec<Real> a, SimdVec<Real> b) {
  return {hn::Min(a.v, b.v)};
}
template <class Real>
HWY_INLINE SimdVec<Real> simd_sqrt(SimdVec<Real> x) {
  return {hn::Sqrt(x.v)};
}
HWY_INLINE double simd_sqrt(double x) { return std::sqrt(x); }
template <class Real>
HWY_INLINE SimdVec<Real> simd_abs(SimdVec<Real> x) {
  return {hn::Abs(x.v)};
}
// e^x, within 1 ulp (Highway's contrib/math).
template <class Real>
HWY_INLINE SimdVec<Real> simd_exp(SimdVec<Real> x) {
  return {hn::Exp(typename SimdVec<Real>::Tag(), x.v)};
}
template <class Real>
HWY_INLINE SimdVec<Real> simd_max(SimdVec<Real> a, SimdVec<Real> b) {
  return {hn::Max(a.v, b.v)};
}
template <class Real>
HWY_INLINE double simd_min_lane(SimdVec<Real> x) {
  return static_cast<double>(hn::GetLane(hn::MinOfLanes(typename SimdVec<Real>::Tag(), x.v)));
}

// a·b + c as one explicit operation (fused where the target has FMA), for scalars and vectors
// alike. Where a sum's rounding must not depend on its surroundings: the compiler's own
// contraction of a·b + c into an FMA can change with what else uses a·b (seen on AVX2: the force
// kernel with energies and without rounded the same force differently).
HWY_INLINE double mul_add(double a, double b, double c) { return a * b + c; }
template <class Real>
HWY_INLINE SimdVec<Real> mul_add(SimdVec<Real> a, SimdVec<Real> b, SimdVec<Real> c) {
  return {hn::MulAdd(a.v, b.v, c.v)};
}

// max(x, 0), for scalars and vectors alike (the kernels are templates on the number type).
HWY_INLINE double positive_part(double x) { return x > 0 ? x : 0.0; }
template <class Real>
HWY_INLINE SimdVec<Real> positive_part(SimdVec<Real> x) {
  return {hn::Max(x.v, hn::Zero(typename SimdVec<Real>::Tag()))};
}

}  // namespace HWY_NAMESPACE
}  // namespace vimd
HWY_AFTER_NAMESPACE();

#endif  // VIMD_SIMD_SIMD_INL_H_
