#pragma once
// Eight doubles as one value, for the pair loops: GCC/Clang vector extensions, which the compiler
// maps onto AVX-512, AVX2 or SSE registers (or scalar code elsewhere), so the force-field kernels
// (forcefields/lennard_jones.hpp, reaction_field.hpp) are written once and instantiated for double
// (reference sums, tests) and for SimdDouble (pair loop). Only the square root and the mask-to-bits
// conversion have per-ISA code (std::sqrt keeps errno semantics and GCC does not vectorise it; the
// portable bit gathering takes a few more instructions).
#include <cmath>
#include <cstdint>
#include <cstring>

#if defined(__AVX512F__) || defined(__AVX__) || defined(__SSE2__)
#include <immintrin.h>
#endif

namespace vimd {

constexpr int kSimdWidth = 8;
typedef double SimdDouble __attribute__((vector_size(kSimdWidth * sizeof(double))));
typedef std::int64_t SimdMask __attribute__((vector_size(kSimdWidth * sizeof(std::int64_t))));  // lanes 0 or −1

inline SimdDouble simd_load(const double* p) {
  SimdDouble v;
  std::memcpy(&v, p, sizeof v);
  return v;
}
inline void simd_store(double* p, SimdDouble v) { std::memcpy(p, &v, sizeof v); }
inline SimdDouble simd_broadcast(double x) { return SimdDouble{} + x; }
inline double simd_sum(SimdDouble v) {
  double s = 0;
  for (int k = 0; k < kSimdWidth; ++k) s += v[k];
  return s;
}
inline SimdDouble select(SimdMask m, SimdDouble a, SimdDouble b) { return m ? a : b; }

// Bit k set where lane k of m is true.
inline unsigned simd_bits(SimdMask m) {
#if defined(__AVX512DQ__)
  __m512i v;
  std::memcpy(&v, &m, sizeof v);
  return _mm512_movepi64_mask(v);
#elif defined(__AVX__)
  __m256d v[2];
  std::memcpy(v, &m, sizeof v);
  return static_cast<unsigned>(_mm256_movemask_pd(v[0]) | (_mm256_movemask_pd(v[1]) << 4));
#else
  typedef std::uint8_t Bytes __attribute__((vector_size(kSimdWidth)));
  const Bytes bytes = __builtin_convertvector(m, Bytes) & 1;
  std::uint64_t word;
  std::memcpy(&word, &bytes, sizeof word);
  return static_cast<unsigned>((word * 0x0102040810204080ull) >> 56);  // byte k (0 or 1) → bit 56 + k
#endif
}

inline SimdDouble simd_sqrt(SimdDouble x) {
#if defined(__AVX512F__)
  __m512d v;
  std::memcpy(&v, &x, sizeof v);
  v = _mm512_mask_sqrt_pd(v, 0xff, v);  // the unmasked form trips GCC 12's -Wmaybe-uninitialized
  std::memcpy(&x, &v, sizeof v);
#elif defined(__AVX__)
  __m256d v[2];
  std::memcpy(v, &x, sizeof v);
  v[0] = _mm256_sqrt_pd(v[0]);
  v[1] = _mm256_sqrt_pd(v[1]);
  std::memcpy(&x, v, sizeof v);
#elif defined(__SSE2__)
  __m128d v[4];
  std::memcpy(v, &x, sizeof v);
  for (auto& w : v) w = _mm_sqrt_pd(w);
  std::memcpy(&x, v, sizeof v);
#else
  for (int k = 0; k < kSimdWidth; ++k) x[k] = std::sqrt(x[k]);
#endif
  return x;
}

// max(x, 0), for scalars and vectors alike (the kernels are templates on the number type).
inline double positive_part(double x) { return x > 0 ? x : 0.0; }
inline SimdDouble positive_part(SimdDouble x) { return x > 0.0 ? x : SimdDouble{}; }

}  // namespace vimd
