#pragma once
// SETTLE's rotation and the velocity projection (engine/settle.cpp) for a batch of rigid 3-site
// molecules at once, in vectors of the chosen SIMD target (settle_kernels.cpp; simd::use_target
// chooses for all kernels).
namespace vimd {

// Structure of arrays: field f of molecule k at [f * kSettleBatch + k].
inline constexpr int kSettleBatch = 64;
// In, per molecule, in the apex-centred frame: the reference bonds apex→h1 (b0) and apex→h2 (c0),
// the unconstrained bonds (b1, c1), the mass fraction m_H / M of each base atom, the body frame's
// apex height ra, base depth rb and half base rc, and the side and base lengths.
enum SettleIn { kB0x, kB0y, kB0z, kC0x, kC0y, kC0z, kB1x, kB1y, kB1z, kC1x, kC1y, kC1z, kBaseWeight, kRa, kRb, kRc,
                kSide, kBase, kSettleInFields };
// Out: the constrained positions of apex, h1 and h2 relative to the unconstrained apex, and the
// relative deviations of their sides apex–h1, apex–h2 and base (NaN where the rotation failed).
enum SettleOut { kAx, kAy, kAz, kBx, kBy, kBz, kCx, kCy, kCz, kDeviationAB, kDeviationAC, kDeviationBC,
                 kSettleOutFields };
using SettleKernel = void (*)(int count, const double* in, double* out);

// The velocity projection of a batch of rigid 3-site molecules (constraints a = 0, 1, 2), in the
// same layout. In: the bond vectors r_a, the rates r_a·(v_i − v_j) and the symmetric weight factors
// c_ab of S_ab = c_ab r_a·r_b. Out: the multipliers x = S⁻¹ rate.
enum ProjectionIn { kR0x, kR0y, kR0z, kR1x, kR1y, kR1z, kR2x, kR2y, kR2z, kRate0, kRate1, kRate2, kC00, kC11, kC22,
                    kC01, kC02, kC12, kProjectionInFields };
using ProjectionKernel = void (*)(int count, const double* in, double* out);

namespace simd {
SettleKernel settle_kernel();
ProjectionKernel triangle_projection_kernel();
}  // namespace simd

}  // namespace vimd
