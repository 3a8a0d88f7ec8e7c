#pragma once
// The neighbour search's inner loop, compiled for every SIMD target (cluster_pair_kernels.cpp)
// and chosen at run time with the pair kernels' target (simd::use_target).
#include <cstdint>

namespace vimd {

// For clusters A (slots a_first .. a_first + 8) and B (b_first ..) shifted by `shift`, positions
// in slot order: bit (i * 8 + j) is set if atoms i of A and j of B are closer than √range2;
// nearest2[h] = the smallest squared distance between half h of A (atoms 4h .. 4h + 3) and B.
using ClusterPairKernel = std::uint64_t (*)(const double* x, const double* y, const double* z, int a_first,
                                            int b_first, const double shift[3], double range2, double nearest2[2]);

// Bit c is set if the bounding box of cluster b0 + c (lower corners lo[0..2][b0 + c], upper
// hi[..]) shifted by `shift` is closer than √range2 to the box [a_lo, a_hi], for c < kBoxBatch.
inline constexpr int kBoxBatch = 8;  // clusters whose bounding boxes are tested together
using BoxBatchKernel = unsigned (*)(const double* const lo[3], const double* const hi[3], int b0, const double a_lo[3],
                                    const double a_hi[3], const double shift[3], double range2);

namespace simd {
ClusterPairKernel cluster_pair_kernel();
BoxBatchKernel box_batch_kernel();
}  // namespace simd

}  // namespace vimd
