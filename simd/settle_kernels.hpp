#pragma once
// SETTLE's rotation and the velocity projection (engine/settle.cpp) for a batch of rigid 3-site
// molecules at once, in vectors of the chosen SIMD target (settle_kernels.cpp; simd::use_target
// chooses for all kernels).
namespace vimd {

// Structure of arrays: field f of molecule k at [f * kSettleBatch + k]. The threads take whole
// batches: small ones keep their shares near equal on small boxes.
inline constexpr int kSettleBatch = 32;
// In, per molecule: the reference positions (q_ref) and the unconstrained positions (q) of the apex,
// h1 and h2 as they are stored (not imaged), the three atoms' weights, and the side and base lengths.
enum SettleIn { kRefAx, kRefAy, kRefAz, kRefBx, kRefBy, kRefBz, kRefCx, kRefCy, kRefCz,
                kQAx, kQAy, kQAz, kQBx, kQBy, kQBz, kQCx, kQCy, kQCz,
                kWeightA, kWeightB, kWeightC, kSide, kBase, kSettleInFields };
// Out: what became of each molecule (SettleStatus); the new positions of apex, h1 and h2 (stored
// coordinates, same images as q: q itself where already satisfied); where SettleParams asks for
// them, their step velocities (new − q_ref) · inverse_step_h; the largest relative deviation of the
// three sides and which side it is (0: apex–h1, 1: apex–h2, 2: base; the first of equals, 0 if all
// are 0).
// Positions, velocities and deviations are meaningful only where the status is not `newton`.
enum SettleOut { kNewAx, kNewAy, kNewAz, kNewBx, kNewBy, kNewBz, kNewCx, kNewCy, kNewCz,
                 kVelAx, kVelAy, kVelAz, kVelBx, kVelBy, kVelBz, kVelCx, kVelCy, kVelCz,
                 kDeviation, kWorstSide, kStatus, kSettleOutFields };
// newton: SETTLE does not apply (q_ref off the constraints, or weights it cannot take) or its
// result misses the tolerance (also a NaN: a displacement too large for the triangle); Newton
// solves those from the untouched q.
enum class SettleStatus { newton = 0, already_satisfied = 1, rotated = 2 };
struct SettleParams {
  double tolerance;
  double box[3];  // periodic lengths, 0 where not periodic
  bool step_velocities = false;
  double inverse_step_h = 0;  // 1 / StepVelocity::h (h is negative in some composition sub-steps)
};
using SettleKernel = void (*)(int count, const SettleParams& params, const double* in, double* out);

// The velocity projection of a batch of rigid 3-site molecules (constraints a = 0, 1, 2), in the
// same layout. In: the bond vectors r_a, the rates r_a·(v_i − v_j) and the symmetric weight factors
// c_ab of S_ab = c_ab r_a·r_b. Out: the multipliers x = S⁻¹ rate.
enum ProjectionIn { kR0x, kR0y, kR0z, kR1x, kR1y, kR1z, kR2x, kR2y, kR2z, kRate0, kRate1, kRate2, kC00, kC11, kC22,
                    kC01, kC02, kC12, kProjectionInFields };
using ProjectionKernel = void (*)(int count, const double* in, double* out);

// A batch's positions between the stored coordinates and the fields above, whole vectors at a time,
// for a batch whose molecules are consecutive atoms (apex, h1, h2, apex, ...: a water box as
// written): fields first..first+8 of lanes [0, count) from or to the 9·count doubles at `coords`.
// A load may fill lanes past count, up to the next multiple of the vector width.
using ConsecutiveLoad = void (*)(const double* coords, int count, double* in, int first);
using ConsecutiveStore = void (*)(const double* out, int first, int count, double* coords);

namespace simd {
SettleKernel settle_kernel();
ConsecutiveLoad consecutive_load();
ConsecutiveStore consecutive_store();
ProjectionKernel triangle_projection_kernel();
}  // namespace simd

}  // namespace vimd
