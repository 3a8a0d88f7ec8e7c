// simd_rsqrt (simd/simd-inl.h), the 1/√x of the pair loops and of SETTLE, against 1/√x in long
// double on every SIMD target this CPU runs: the kernels' checks against brute-force sums pass at
// 1e-12, which would not notice the double-precision refinement losing a few bits. The per-target
// part is compiled here for each target (Highway's foreach_target re-includes this file).
#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "tests/test_simd_math.cpp"
#include "hwy/foreach_target.h"  // IWYU pragma: keep

#include "simd/simd-inl.h"
#include "hwy/highway.h"

HWY_BEFORE_NAMESPACE();
namespace vimd {
namespace HWY_NAMESPACE {

// y[i] = simd_rsqrt(x[i]) for whole vectors of x (n a multiple of every target's lanes).
template <class Real>
void rsqrt_vectors(const Real* x, Real* y, int n) {
  const int lanes = static_cast<int>(hn::Lanes(typename SimdVec<Real>::Tag()));
  for (int i = 0; i + lanes <= n; i += lanes) simd_store(y + i, simd_rsqrt(simd_load(x + i)));
}
void RsqrtDouble(const double* x, double* y, int n) { rsqrt_vectors(x, y, n); }
void RsqrtFloat(const float* x, float* y, int n) { rsqrt_vectors(x, y, n); }

}  // namespace HWY_NAMESPACE
}  // namespace vimd
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "forcefields/nonbonded/nonbonded_kernels.hpp"
#include "simd/targets.hpp"

namespace vimd {
HWY_EXPORT(RsqrtDouble);
HWY_EXPORT(RsqrtFloat);
namespace {

// Arguments spread evenly in log x over [10^lo, 10^hi], a multiple of 16 of them.
template <class Real>
std::vector<Real> log_spread(double lo, double hi, int n, unsigned seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> exponent(lo, hi);
  std::vector<Real> x(n);
  for (Real& v : x) v = static_cast<Real>(std::pow(10.0, exponent(rng)));
  return x;
}

// The largest relative error of simd_rsqrt over x on the chosen target.
template <class Real, class Kernel>
long double worst_relative_error(Kernel kernel, const std::vector<Real>& x) {
  std::vector<Real> y(x.size());
  kernel(x.data(), y.data(), static_cast<int>(x.size()));
  long double worst = 0;
  for (std::size_t i = 0; i < x.size(); ++i) {
    const long double exact = 1.0L / std::sqrt(static_cast<long double>(x[i]));
    worst = std::max(worst, std::fabs(static_cast<long double>(y[i]) - exact) / exact);
  }
  return worst;
}

class SimdRsqrt : public ::testing::Test {
 protected:
  void TearDown() override { simd::use_target(""); }

  // On every target: within `bound` relative, from the pair loops' floor on r² (3.8e-7 nm²) up to
  // 10, and over 10^-30 .. 10^30. kernel(x, y, n) calls the chosen target's function.
  template <class Real, class Kernel>
  static void expect_within(Kernel kernel, long double bound, unsigned seed) {
    const std::vector<Real> pair_range = log_spread<Real>(std::log10(3.8e-7), 1.0, 1 << 14, seed);
    const std::vector<Real> wide = log_spread<Real>(-30.0, 30.0, 1 << 14, seed + 1);
    for (const std::string& target : simd::available_targets()) {
      SCOPED_TRACE(target);
      simd::use_target(target);
      EXPECT_LE(worst_relative_error(kernel, pair_range), bound);
      EXPECT_LE(worst_relative_error(kernel, wide), bound);
    }
  }
};

// Double precision: the series after the single-precision estimate (AVX2, SSE4) or two Newton
// steps after AVX-512's 14-bit one leave a few roundings, not lost bits: within 4 ulp (2^-50).
TEST_F(SimdRsqrt, DoubleIsFullPrecisionOnEveryTarget) {
  expect_within<double>([](const double* x, double* y, int n) { HWY_DYNAMIC_DISPATCH(RsqrtDouble)(x, y, n); },
                        std::ldexp(1.0L, -50), 1);
}

// Single precision: the 12-bit estimate and one Newton step, 3e²/8 ≈ 2e-7 for its |e| < 7.4e-4,
// plus roundings: within 2^-21 (4 float ulp).
TEST_F(SimdRsqrt, SingleIsWithinFourUlpOnEveryTarget) {
  expect_within<float>([](const float* x, float* y, int n) { HWY_DYNAMIC_DISPATCH(RsqrtFloat)(x, y, n); },
                       std::ldexp(1.0L, -21), 3);
}

}  // namespace
}  // namespace vimd
#endif  // HWY_ONCE
