#pragma once
// The neighbour search's inner loop, compiled for every SIMD target (cluster_pair_kernels.cpp)
// and chosen at run time with the pair kernels' target (simd::use_target).
#include <cstdint>

namespace vimd {

inline constexpr int kBoxBatch = 8;  // clusters whose bounding boxes are tested together

// Positions in slot order, in single precision. For each candidate j-cluster b0 + c (bit c of
// `candidates`, c < kBoxBatch) against i-cluster A (slots a_first .. a_first + 8) shifted by −shift:
// near[c] has bit (i * 8 + j) set if atoms i of A and j of the candidate are closer than √range2, and
// nearest[c][h] is the smallest distance from half h of A (atoms 4h .. 4h + 3) to it less
// `rounding` (at least 0), all in single-precision arithmetic: with range2 widened by `rounding`, a
// bound on the distances' rounding errors, no pair within the unwidened range is missed and nearest
// is a lower bound. The other c of near and nearest are left unspecified.
using ClusterPairKernel = void (*)(const float* x, const float* y, const float* z, int a_first, int b0,
                                   unsigned candidates, const float shift[3], float range2, float rounding,
                                   std::uint64_t near[kBoxBatch], float nearest[kBoxBatch][2]);

// Bit c is set if the bounding box of cluster b0 + c (lower corners lo[0..2][b0 + c], upper
// hi[..]) shifted by `shift` is closer than √range2 to the box [a_lo, a_hi], for c < kBoxBatch.
using BoxBatchKernel = unsigned (*)(const double* const lo[3], const double* const hi[3], int b0, const double a_lo[3],
                                    const double a_hi[3], const double shift[3], double range2);

namespace simd {
ClusterPairKernel cluster_pair_kernel();
BoxBatchKernel box_batch_kernel();
}  // namespace simd

}  // namespace vimd
