// The cluster-pair distance test of the neighbour search, once per SIMD target (Highway's
// foreach_target re-includes this file for each), dispatched at run time: 8 x 8 distances in
// vectors of the target's width instead of the baseline's two doubles.
#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "engine/cluster_pair_kernels.cpp"
#include "hwy/foreach_target.h"  // IWYU pragma: keep

#include "engine/cluster_pair_kernels.hpp"
#include "engine/simd-inl.h"
#include "hwy/highway.h"

HWY_BEFORE_NAMESPACE();
namespace vimd {
namespace HWY_NAMESPACE {
namespace {

constexpr int kCluster = 8, kHalf = 4;

std::uint64_t cluster_pair_near(const double* x, const double* y, const double* z, int a_first, int b_first,
                                const double shift[3], double range2, double nearest2[2]) {
  const int lanes = SimdDouble::lanes();
  std::uint64_t near = 0;
  SimdDouble closest[2] = {SimdDouble::broadcast(HUGE_VAL), SimdDouble::broadcast(HUGE_VAL)};
  for (int j0 = 0; j0 < kCluster; j0 += lanes) {
    const SimdDouble xj = simd_load(x + b_first + j0) + shift[0], yj = simd_load(y + b_first + j0) + shift[1],
                     zj = simd_load(z + b_first + j0) + shift[2];
    for (int i = 0; i < kCluster; ++i) {
      const SimdDouble dx = x[a_first + i] - xj, dy = y[a_first + i] - yj, dz = z[a_first + i] - zj;
      const SimdDouble r2 = dx * dx + dy * dy + dz * dz;
      near |= static_cast<std::uint64_t>(bits_from_mask(r2 < range2)) << (i * kCluster + j0);
      closest[i / kHalf] = simd_min(closest[i / kHalf], r2);
    }
  }
  for (int h = 0; h < 2; ++h) nearest2[h] = simd_min_lane(closest[h]);
  return near;
}

unsigned box_batch_near(const double* const lo[3], const double* const hi[3], int b0, const double a_lo[3],
                        const double a_hi[3], const double shift[3], double range2) {
  const int lanes = SimdDouble::lanes();
  unsigned near = 0;
  for (int c0 = 0; c0 < kBoxBatch; c0 += lanes) {
    SimdDouble d2 = SimdDouble::zero();
    for (int k = 0; k < 3; ++k) {
      const SimdDouble above = (simd_load(lo[k] + b0 + c0) + shift[k]) - a_hi[k];
      const SimdDouble below = a_lo[k] - (simd_load(hi[k] + b0 + c0) + shift[k]);
      const SimdDouble gap = positive_part(simd_max(above, below));
      d2 += gap * gap;
    }
    near |= bits_from_mask(d2 < range2) << c0;
  }
  return near;
}

}  // namespace

ClusterPairKernel ClusterPairKernelFor() { return cluster_pair_near; }
BoxBatchKernel BoxBatchKernelFor() { return box_batch_near; }

}  // namespace HWY_NAMESPACE
}  // namespace vimd
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace vimd {
HWY_EXPORT(ClusterPairKernelFor);
HWY_EXPORT(BoxBatchKernelFor);
namespace simd {
ClusterPairKernel cluster_pair_kernel() { return HWY_DYNAMIC_DISPATCH(ClusterPairKernelFor)(); }
BoxBatchKernel box_batch_kernel() { return HWY_DYNAMIC_DISPATCH(BoxBatchKernelFor)(); }
}  // namespace simd
}  // namespace vimd
#endif  // HWY_ONCE
