#pragma once
// The per-atom passes of every step (the velocity Verlet kicks and drift, the displacement that
// decides when the pair list is redone, the run loop's sanity scan), in vectors of the chosen SIMD
// target (atom_kernels.cpp; simd::use_target chooses for all kernels): coordinates as stored (x, y,
// z of atom 0, then of atom 1, ...), read and written de-interleaved, one atom per lane. The
// arithmetic is the scalar loops', operation by operation (no fused multiply-adds): every target
// gives the same bits.

namespace vimd {

// v += (h·w_i)·f for atoms [0, n): w the inverse masses.
using KickKernel = void (*)(int n, const double* inverse_mass, double h, const double* f, double* v);
// v += (h_kick·w_i)·f, then q_before = q (unless null), then q += h_drift·v.
using KickDriftKernel = void (*)(int n, const double* inverse_mass, double h_kick, double h_drift, const double* f,
                                 double* v, double* q, double* q_before);
// max_i |a_i − b_i|² over atoms [0, n).
using MaxSquaredDisplacementKernel = double (*)(int n, const double* a, const double* b);
// Whether |x_i|² ≤ limit² for every atom of [0, n) (false for a NaN); x copied to `copy` on the way,
// unless it is null.
using WithinNormKernel = bool (*)(int n, const double* x, double limit, double* copy);

namespace simd {
KickKernel kick_kernel();
KickDriftKernel kick_drift_kernel();
MaxSquaredDisplacementKernel max_squared_displacement_kernel();
WithinNormKernel within_norm_kernel();
}  // namespace simd

}  // namespace vimd
