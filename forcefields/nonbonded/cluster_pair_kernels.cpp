// The cluster-pair distance tests of the neighbour search, once per SIMD target (Highway's
// foreach_target re-includes this file for each), dispatched at run time: 8 x 8 distances in
// single-precision vectors of the target's width, laid out as the pair loops' (pair_layout-inl.h).
#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "forcefields/nonbonded/cluster_pair_kernels.cpp"
#include "hwy/foreach_target.h"  // IWYU pragma: keep

#include "forcefields/nonbonded/cluster_pair_kernels.hpp"
#include "forcefields/nonbonded/pair_layout-inl.h"
#include "simd/simd-inl.h"
#include "hwy/highway.h"

HWY_BEFORE_NAMESPACE();
namespace vimd {
namespace HWY_NAMESPACE {
namespace {

constexpr int kCluster = NeighborList::kClusterSize, kHalf = NeighborList::kHalfSize;

void cluster_pair_near(const float* x, const float* y, const float* z, int a_first, int b0, unsigned candidates,
                       const float shift[3], float range2, float rounding, std::uint64_t near[kBoxBatch],
                       float nearest[kBoxBatch][2]) {
  using V = SimdFloat;
  using L = PairLayout<float>;
  constexpr int kRows = L::kRows, kJ = L::kJLanes, kVectors = kCluster / kRows;
  // The shift moves the i atoms once for all candidates instead of every j atom.
  V xi[kVectors], yi[kVectors], zi[kVectors];
  for (int r = 0; r < kVectors; ++r) {
    xi[r] = broadcast_rows(x + a_first, r * kRows) - shift[0];
    yi[r] = broadcast_rows(y + a_first, r * kRows) - shift[1];
    zi[r] = broadcast_rows(z + a_first, r * kRows) - shift[2];
  }
  const V range2_v = V::broadcast(range2);
  for (; candidates; candidates &= candidates - 1) {
    const int c = __builtin_ctz(candidates);
    const int jb = (b0 + c) * kCluster;
    std::uint64_t bits = 0;
    V closest[2] = {V::broadcast(HUGE_VALF), V::broadcast(HUGE_VALF)};
    for (int js = 0; js < kCluster; js += kJ) {
      const V xj = load_j(x + jb + js), yj = load_j(y + jb + js), zj = load_j(z + jb + js);
#pragma GCC unroll 8
      for (int r = 0; r < kVectors; ++r) {
        // x_j − x_i: the i positions are the operand x86 can read from memory, where they do not all
        // fit in registers.
        const V dx = xj - xi[r], dy = yj - yi[r], dz = zj - zi[r];
        const V r2 = dx * dx + dy * dy + dz * dz;
        bits |= static_cast<std::uint64_t>(bits_from_mask(r2 < range2_v)) << (r * kRows * kCluster + js);
        closest[r * kRows / kHalf] = simd_min(closest[r * kRows / kHalf], r2);
      }
    }
    near[c] = bits;
    for (int h = 0; h < 2; ++h) nearest[c][h] = static_cast<float>(simd_min_lane(closest[h]));
  }
  // Squared distances to distances for all candidates at once (the others' values are unspecified
  // but finite, as left by an earlier call).
  float* const all = &nearest[0][0];
  for (int k = 0; k < 2 * kBoxBatch; k += V::lanes())
    simd_store(all + k, positive_part(simd_sqrt(simd_load(all + k)) - rounding));
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
