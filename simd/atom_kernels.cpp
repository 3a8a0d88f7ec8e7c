// The per-atom passes (atom_kernels.hpp), once per SIMD target (Highway's foreach_target
// re-includes this file): whole vectors of atoms, the last few atoms one at a time with the same
// operations.
#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "simd/atom_kernels.cpp"
#include "hwy/foreach_target.h"  // IWYU pragma: keep

#include <algorithm>

#include "simd/atom_kernels.hpp"
#include "simd/simd-inl.h"
#include "hwy/highway.h"

HWY_BEFORE_NAMESPACE();
namespace vimd {
namespace HWY_NAMESPACE {
namespace {

using D = SimdTag;
using V = hn::Vec<D>;

void kick(int n, const double* inverse_mass, double h, const double* f, double* v) {
  const D d;
  const int lanes = static_cast<int>(hn::Lanes(d));
  const V hv = hn::Set(d, h);
  int i = 0;
  for (; i + lanes <= n; i += lanes) {
    const V s = hn::Mul(hv, hn::LoadU(d, inverse_mass + i));
    V fx, fy, fz, vx, vy, vz;
    hn::LoadInterleaved3(d, f + 3 * i, fx, fy, fz);
    hn::LoadInterleaved3(d, v + 3 * i, vx, vy, vz);
    hn::StoreInterleaved3(hn::Add(vx, hn::Mul(s, fx)), hn::Add(vy, hn::Mul(s, fy)), hn::Add(vz, hn::Mul(s, fz)), d,
                          v + 3 * i);
  }
  for (; i < n; ++i) {
    const double s = h * inverse_mass[i];
    for (int k = 0; k < 3; ++k) v[3 * i + k] += s * f[3 * i + k];
  }
}

void kick_drift(int n, const double* inverse_mass, double h_kick, double h_drift, const double* f, double* v,
                double* q, double* q_before) {
  const D d;
  const int lanes = static_cast<int>(hn::Lanes(d));
  const V hk = hn::Set(d, h_kick), hd = hn::Set(d, h_drift);
  int i = 0;
  for (; i + lanes <= n; i += lanes) {
    const V s = hn::Mul(hk, hn::LoadU(d, inverse_mass + i));
    V fx, fy, fz, vx, vy, vz, qx, qy, qz;
    hn::LoadInterleaved3(d, f + 3 * i, fx, fy, fz);
    hn::LoadInterleaved3(d, v + 3 * i, vx, vy, vz);
    vx = hn::Add(vx, hn::Mul(s, fx));
    vy = hn::Add(vy, hn::Mul(s, fy));
    vz = hn::Add(vz, hn::Mul(s, fz));
    hn::StoreInterleaved3(vx, vy, vz, d, v + 3 * i);
    if (q_before) std::copy(q + 3 * i, q + 3 * (i + lanes), q_before + 3 * i);
    hn::LoadInterleaved3(d, q + 3 * i, qx, qy, qz);
    hn::StoreInterleaved3(hn::Add(qx, hn::Mul(hd, vx)), hn::Add(qy, hn::Mul(hd, vy)), hn::Add(qz, hn::Mul(hd, vz)), d,
                          q + 3 * i);
  }
  for (; i < n; ++i) {
    const double s = h_kick * inverse_mass[i];
    for (int k = 0; k < 3; ++k) {
      const int c = 3 * i + k;
      v[c] += s * f[c];
      if (q_before) q_before[c] = q[c];
      q[c] += h_drift * v[c];
    }
  }
}

double max_squared_displacement(int n, const double* a, const double* b) {
  const D d;
  const int lanes = static_cast<int>(hn::Lanes(d));
  V largest = hn::Zero(d);
  int i = 0;
  for (; i + lanes <= n; i += lanes) {
    V ax, ay, az, bx, by, bz;
    hn::LoadInterleaved3(d, a + 3 * i, ax, ay, az);
    hn::LoadInterleaved3(d, b + 3 * i, bx, by, bz);
    const V dx = hn::Sub(ax, bx), dy = hn::Sub(ay, by), dz = hn::Sub(az, bz);
    largest = hn::Max(largest, hn::Add(hn::Add(hn::Mul(dx, dx), hn::Mul(dy, dy)), hn::Mul(dz, dz)));
  }
  double result = hn::GetLane(hn::MaxOfLanes(d, largest));
  for (; i < n; ++i) {
    const double dx = a[3 * i] - b[3 * i], dy = a[3 * i + 1] - b[3 * i + 1], dz = a[3 * i + 2] - b[3 * i + 2];
    result = std::max(result, dx * dx + dy * dy + dz * dz);
  }
  return result;
}

bool within_norm(int n, const double* x, double limit, double* copy) {
  const D d;
  const int lanes = static_cast<int>(hn::Lanes(d));
  const double limit2 = limit * limit;
  const V lv = hn::Set(d, limit2);
  auto all_within = hn::Eq(lv, lv);
  int i = 0;
  for (; i + lanes <= n; i += lanes) {
    V xx, xy, xz;
    hn::LoadInterleaved3(d, x + 3 * i, xx, xy, xz);
    // Le is false for a NaN.
    all_within = hn::And(all_within, hn::Le(hn::Add(hn::Add(hn::Mul(xx, xx), hn::Mul(xy, xy)), hn::Mul(xz, xz)), lv));
    if (copy)
      for (int part = 0; part < 3; ++part)
        hn::StoreU(hn::LoadU(d, x + 3 * i + part * lanes), d, copy + 3 * i + part * lanes);
  }
  bool within = hn::AllTrue(d, all_within);
  for (; i < n; ++i) {
    within = within && x[3 * i] * x[3 * i] + x[3 * i + 1] * x[3 * i + 1] + x[3 * i + 2] * x[3 * i + 2] <= limit2;
    if (copy) std::copy(x + 3 * i, x + 3 * i + 3, copy + 3 * i);
  }
  return within;
}

}  // namespace

KickKernel KickKernelFor() { return kick; }
KickDriftKernel KickDriftKernelFor() { return kick_drift; }
MaxSquaredDisplacementKernel MaxSquaredDisplacementKernelFor() { return max_squared_displacement; }
WithinNormKernel WithinNormKernelFor() { return within_norm; }

}  // namespace HWY_NAMESPACE
}  // namespace vimd
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace vimd {
HWY_EXPORT(KickKernelFor);
HWY_EXPORT(KickDriftKernelFor);
HWY_EXPORT(MaxSquaredDisplacementKernelFor);
HWY_EXPORT(WithinNormKernelFor);
namespace simd {
KickKernel kick_kernel() { return HWY_DYNAMIC_DISPATCH(KickKernelFor)(); }
KickDriftKernel kick_drift_kernel() { return HWY_DYNAMIC_DISPATCH(KickDriftKernelFor)(); }
MaxSquaredDisplacementKernel max_squared_displacement_kernel() {
  return HWY_DYNAMIC_DISPATCH(MaxSquaredDisplacementKernelFor)();
}
WithinNormKernel within_norm_kernel() { return HWY_DYNAMIC_DISPATCH(WithinNormKernelFor)(); }
}  // namespace simd
}  // namespace vimd
#endif  // HWY_ONCE
