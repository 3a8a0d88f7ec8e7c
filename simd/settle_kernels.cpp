// SETTLE (Miyamoto & Kollman, J. Comput. Chem. 13, 952 (1992)) and the velocity projection for a
// batch of molecules, once per SIMD target (Highway's foreach_target re-includes this file), one
// molecule per lane: their square roots and divisions, latency-bound one molecule at a time,
// overlap across the lanes.
#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "simd/settle_kernels.cpp"
#include "hwy/foreach_target.h"  // IWYU pragma: keep

#include <algorithm>

#include "simd/settle_kernels.hpp"
#include "simd/simd-inl.h"
#include "hwy/highway.h"

HWY_BEFORE_NAMESPACE();
namespace vimd {
namespace HWY_NAMESPACE {
namespace {

using V = SimdDouble;

struct V3 {
  V x, y, z;
};
HWY_INLINE V3 operator+(const V3& a, const V3& b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
HWY_INLINE V3 operator-(const V3& a, const V3& b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
HWY_INLINE V3 operator*(V s, const V3& a) { return {s * a.x, s * a.y, s * a.z}; }
HWY_INLINE V dot(const V3& a, const V3& b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
HWY_INLINE V3 cross(const V3& a, const V3& b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
HWY_INLINE V3 normalized(const V3& a) { return simd_rsqrt(dot(a, a)) * a; }

// Minimum image along one axis of length L (0: not periodic), as Box::minimum_image.
HWY_INLINE V minimum_image(V d, double length) {
  if (!(length > 0)) return d;
  const SimdTag tag;
  const auto far = hn::Gt(simd_abs(d).v, hn::Set(tag, 0.5 * length));
  if (hn::AllFalse(tag, far)) return d;  // as nearly always: the division is the costly part
  return {hn::IfThenElse(far, (d - length * V{hn::Round((d / length).v)}).v, d.v)};
}
HWY_INLINE V3 minimum_image(const V3& d, const double* box) {
  return {minimum_image(d.x, box[0]), minimum_image(d.y, box[1]), minimum_image(d.z, box[2])};
}
// r² inside [(d(1 − tol))², (d(1 + tol))²], as constraint_internals::within.
HWY_INLINE auto within(V r2, V d, double tolerance) {
  const V lo = d * (1 - tolerance), hi = d * (1 + tolerance);
  return hn::And(hn::Ge(r2.v, (lo * lo).v), hn::Le(r2.v, (hi * hi).v));
}
HWY_INLINE V deviation(const V3& r, V length) { return simd_abs(simd_sqrt(dot(r, r)) - length) / length; }

// One lane-batch of molecules: their reference triangle in its minimum images, and whether SETTLE
// applies to it.
struct Reference {
  V3 b0, c0;                // base atoms relative to the apex, minimum images
  V3 image_b, image_c;      // what the minimum image added to each
  V w_a, w_b, side, base;   // weights and the triangle's sides
  hn::Mask<SimdTag> applicable;
};

HWY_INLINE Reference reference(const double* in, int k, const SettleParams& params) {
  const SimdTag tag;
  auto field = [&](int f) { return simd_load(in + f * kSettleBatch + k); };
  auto point = [&](int f) { return V3{field(f), field(f + 1), field(f + 2)}; };
  Reference r;
  const V3 ref_a = point(kRefAx);
  const V3 raw_b = point(kRefBx) - ref_a, raw_c = point(kRefCx) - ref_a;
  r.b0 = minimum_image(raw_b, params.box), r.c0 = minimum_image(raw_c, params.box);
  r.image_b = r.b0 - raw_b, r.image_c = r.c0 - raw_c;
  r.w_a = field(kWeightA), r.w_b = field(kWeightB), r.side = field(kSide), r.base = field(kBase);
  // SETTLE needs equal base weights, positive weights and q_ref on the constraints.
  const auto weights_fit = hn::And(hn::Eq(r.w_b.v, field(kWeightC).v),
                                   hn::And(hn::Gt(r.w_a.v, hn::Zero(tag)), hn::Gt(r.w_b.v, hn::Zero(tag))));
  const double tolerance = params.tolerance;
  const auto reference_fits =
      hn::And(hn::And(within(dot(r.b0, r.b0), r.side, tolerance), within(dot(r.c0, r.c0), r.side, tolerance)),
              within(dot(r.c0 - r.b0, r.c0 - r.b0), r.base, tolerance));
  r.applicable = hn::And(weights_fit, reference_fits);
  return r;
}

// The rotated molecule, relative to the unconstrained apex: each atom's new position minus it.
struct Rotated {
  V3 a3, b3, c3;
};

// SETTLE's analytic solution: the molecule of the reference's shape whose centre of mass is the
// unconstrained one (b1_apex, c1_apex: the unconstrained bonds from the apex, in the reference's images).
HWY_INLINE Rotated rotate(const Reference& r, const V3& b1_apex, const V3& c1_apex) {
  const V base_weight = r.w_a / (r.w_b + 2.0 * r.w_a);  // m_H / M
  const V rc = 0.5 * r.base, height = simd_sqrt(r.side * r.side - rc * rc);
  const V ra = 2.0 * base_weight * height, rb = height - ra;
  // Body frame: centre of mass at the origin, apex at (0, ra), base atoms at (∓rc, −rb).
  const V3 com = base_weight * (b1_apex + c1_apex);  // relative to the unconstrained apex
  const V3 a1 = V3{-com.x, -com.y, -com.z}, b1 = b1_apex - com, c1 = c1_apex - com;
  // Frame: z normal to the reference plane, x normal to the apex's offset and z.
  const V3 n0 = normalized(cross(r.b0, r.c0));
  const V3 n1 = normalized(cross(a1, n0));
  const V3 n2 = normalized(cross(n0, n1));
  const V b0x = dot(n1, r.b0), b0y = dot(n2, r.b0), c0x = dot(n1, r.c0), c0y = dot(n2, r.c0);
  const V a1z = dot(n0, a1);
  const V b1x = dot(n1, b1), b1y = dot(n2, b1), b1z = dot(n0, b1);
  const V c1x = dot(n1, c1), c1y = dot(n2, c1), c1z = dot(n0, c1);
  const V sin_phi = a1z / ra, cos_phi = simd_sqrt(1.0 - sin_phi * sin_phi);
  const V sin_psi = (b1z - c1z) / (2.0 * rc * cos_phi), cos_psi = simd_sqrt(1.0 - sin_psi * sin_psi);
  const V a2y = ra * cos_phi, b2x = -(rc * cos_psi);
  const V t1 = -(rb * cos_phi), t2 = rc * sin_psi * sin_phi;
  const V b2y = t1 - t2, c2y = t1 + t2;
  const V alpha = b2x * (b0x - c0x) + b0y * b2y + c0y * c2y;
  const V beta = b2x * (c0y - b0y) + b0x * b2y + c0x * c2y;
  const V gamma = b0x * b1y - b1x * b0y + c0x * c1y - c1x * c0y;
  const V al2be2 = alpha * alpha + beta * beta;
  const V sin_theta = (alpha * gamma - beta * simd_sqrt(al2be2 - gamma * gamma)) / al2be2;
  const V cos_theta = simd_sqrt(1.0 - sin_theta * sin_theta);
  auto lab = [&](V x, V y, V z) { return com + x * n1 + y * n2 + z * n0; };
  return {lab(-(a2y * sin_theta), a2y * cos_theta, a1z),
          lab(b2x * cos_theta - b2y * sin_theta, b2x * sin_theta + b2y * cos_theta, b1z),
          lab(-(b2x * cos_theta) - c2y * sin_theta, -(b2x * sin_theta) + c2y * cos_theta, c1z)};
}

// The new positions of atom a (0 apex, 1 and 2 base) and, if asked, the velocities that reach them.
HWY_INLINE void store_atom(int a, const V3& position, const double* in, double* out, int k, const SettleParams& params) {
  simd_store(out + (kNewAx + 3 * a) * kSettleBatch + k, position.x);
  simd_store(out + (kNewAx + 3 * a + 1) * kSettleBatch + k, position.y);
  simd_store(out + (kNewAx + 3 * a + 2) * kSettleBatch + k, position.z);
  if (!params.step_velocities) return;
  const int ref_field[3] = {kRefAx, kRefBx, kRefCx};
  auto field = [&](int f) { return simd_load(in + f * kSettleBatch + k); };
  simd_store(out + (kVelAx + 3 * a) * kSettleBatch + k, (position.x - field(ref_field[a])) * params.inverse_step_h);
  simd_store(out + (kVelAx + 3 * a + 1) * kSettleBatch + k,
             (position.y - field(ref_field[a] + 1)) * params.inverse_step_h);
  simd_store(out + (kVelAx + 3 * a + 2) * kSettleBatch + k,
             (position.z - field(ref_field[a] + 2)) * params.inverse_step_h);
}

// The largest relative deviation of the three sides from the reference's, which side it is, and
// the status: within tolerance (left as it was, or rotated) or 0 for a molecule SETTLE failed.
HWY_INLINE void store_checks(const V side_deviation[3], hn::Mask<SimdTag> applicable, hn::Mask<SimdTag> satisfied,
                             double* out, int k, double tolerance) {
  const SimdTag tag;
  V largest = V::zero(), worst_side = V::zero();
  auto within_tolerance = applicable;
  for (int s = 0; s < 3; ++s) {
    within_tolerance = hn::And(within_tolerance, hn::Le(side_deviation[s].v, hn::Set(tag, tolerance)));
    const auto larger = hn::Gt(side_deviation[s].v, largest.v);
    largest = V{hn::IfThenElse(larger, side_deviation[s].v, largest.v)};
    worst_side = V{hn::IfThenElse(larger, hn::Set(tag, static_cast<double>(s)), worst_side.v)};
  }
  simd_store(out + kDeviation * kSettleBatch + k, largest);
  simd_store(out + kWorstSide * kSettleBatch + k, worst_side);
  auto status = [&](SettleStatus s) { return hn::Set(tag, static_cast<double>(s)); };
  simd_store(out + kStatus * kSettleBatch + k,
             V{hn::IfThenElseZero(within_tolerance, V{hn::IfThenElse(satisfied, status(SettleStatus::already_satisfied),
                                                                     status(SettleStatus::rotated))}.v)});
}

void settle_batch(int count, const SettleParams& params, const double* in, double* out) {
  const int lanes = V::lanes();
  const double tolerance = params.tolerance;
  auto point = [&](int f, int k) {
    return V3{simd_load(in + f * kSettleBatch + k), simd_load(in + (f + 1) * kSettleBatch + k),
              simd_load(in + (f + 2) * kSettleBatch + k)};
  };
  for (int k = 0; k < count; k += lanes) {
    const Reference r = reference(in, k, params);
    const V3 q_a = point(kQAx, k), q_b = point(kQBx, k), q_c = point(kQCx, k);
    // The unconstrained bonds from the apex, in the reference's images.
    const V3 b1_apex = q_b - q_a + r.image_b, c1_apex = q_c - q_a + r.image_c;
    // Already on the constraints: left exactly as it is, as Newton leaves it.
    const auto satisfied =
        hn::And(r.applicable, hn::And(hn::And(within(dot(b1_apex, b1_apex), r.side, tolerance),
                                              within(dot(c1_apex, c1_apex), r.side, tolerance)),
                                      within(dot(c1_apex - b1_apex, c1_apex - b1_apex), r.base, tolerance)));
    const Rotated m = rotate(r, b1_apex, c1_apex);
    // Back in the stored images of q; q itself where it stays.
    auto pick = [&](const V3& of_q, const V3& rotated) {
      return V3{V{hn::IfThenElse(satisfied, of_q.x.v, rotated.x.v)}, V{hn::IfThenElse(satisfied, of_q.y.v, rotated.y.v)},
                V{hn::IfThenElse(satisfied, of_q.z.v, rotated.z.v)}};
    };
    store_atom(0, pick(q_a, q_a + m.a3), in, out, k, params);
    store_atom(1, pick(q_b, q_a + m.b3 - r.image_b), in, out, k, params);
    store_atom(2, pick(q_c, q_a + m.c3 - r.image_c), in, out, k, params);
    // The sides of q where it stays, of the rotated molecule elsewhere.
    const V side_deviation[3] = {deviation(pick(b1_apex, m.b3 - m.a3), r.side),
                                 deviation(pick(c1_apex, m.c3 - m.a3), r.side),
                                 deviation(pick(c1_apex - b1_apex, m.c3 - m.b3), r.base)};
    store_checks(side_deviation, r.applicable, satisfied, out, k, tolerance);
  }
}

// x = S⁻¹ rate by the symmetric 3×3 adjugate: one division per molecule, no pivoting (S is
// positive definite for a non-degenerate triangle).
void project_triangle_batch(int count, const double* in, double* out) {
  const int lanes = V::lanes();
  auto field = [&](int f, int k) { return simd_load(in + f * kSettleBatch + k); };
  for (int k = 0; k < count; k += lanes) {
    const V3 r0{field(kR0x, k), field(kR0y, k), field(kR0z, k)}, r1{field(kR1x, k), field(kR1y, k), field(kR1z, k)},
        r2{field(kR2x, k), field(kR2y, k), field(kR2z, k)};
    const V s00 = field(kC00, k) * dot(r0, r0), s11 = field(kC11, k) * dot(r1, r1), s22 = field(kC22, k) * dot(r2, r2);
    const V s01 = field(kC01, k) * dot(r0, r1), s02 = field(kC02, k) * dot(r0, r2), s12 = field(kC12, k) * dot(r1, r2);
    const V a00 = s11 * s22 - s12 * s12, a01 = s02 * s12 - s01 * s22, a02 = s01 * s12 - s11 * s02;
    const V a11 = s00 * s22 - s02 * s02, a12 = s01 * s02 - s00 * s12, a22 = s00 * s11 - s01 * s01;
    const V inverse_det = 1.0 / (s00 * a00 + s01 * a01 + s02 * a02);
    const V rate0 = field(kRate0, k), rate1 = field(kRate1, k), rate2 = field(kRate2, k);
    simd_store(out + k, inverse_det * (a00 * rate0 + a01 * rate1 + a02 * rate2));
    simd_store(out + kSettleBatch + k, inverse_det * (a01 * rate0 + a11 * rate1 + a12 * rate2));
    simd_store(out + 2 * kSettleBatch + k, inverse_det * (a02 * rate0 + a12 * rate1 + a22 * rate2));
  }
}

// Positions of consecutive molecules: the coordinates of 3·lanes atoms de-interleaved by xyz, then
// each coordinate's values de-interleaved by apex, h1, h2 (and the reverse to store).
void load_consecutive(const double* coords, int count, double* in, int first) {
  const SimdTag tag;
  const int lanes = V::lanes();
  constexpr int kMaxLanes = HWY_MAX_BYTES / sizeof(double);
  HWY_ALIGN double by_coordinate[3][3 * kMaxLanes];
  HWY_ALIGN double tail[9 * kMaxLanes] = {};
  for (int k = 0; k < count; k += lanes) {
    const double* from = coords + 9 * k;
    if (count - k < lanes) {
      std::copy(from, from + 9 * (count - k), tail);
      from = tail;
    }
    for (int part = 0; part < 3; ++part) {
      hn::Vec<SimdTag> x, y, z;
      hn::LoadInterleaved3(tag, from + 3 * lanes * part, x, y, z);
      hn::Store(x, tag, by_coordinate[0] + lanes * part);
      hn::Store(y, tag, by_coordinate[1] + lanes * part);
      hn::Store(z, tag, by_coordinate[2] + lanes * part);
    }
    for (int d = 0; d < 3; ++d) {
      hn::Vec<SimdTag> apex, h1, h2;
      hn::LoadInterleaved3(tag, by_coordinate[d], apex, h1, h2);
      hn::StoreU(apex, tag, in + (first + d) * kSettleBatch + k);
      hn::StoreU(h1, tag, in + (first + 3 + d) * kSettleBatch + k);
      hn::StoreU(h2, tag, in + (first + 6 + d) * kSettleBatch + k);
    }
  }
}

void store_consecutive(const double* out, int first, int count, double* coords) {
  const SimdTag tag;
  const int lanes = V::lanes();
  constexpr int kMaxLanes = HWY_MAX_BYTES / sizeof(double);
  HWY_ALIGN double by_coordinate[3][3 * kMaxLanes];
  HWY_ALIGN double tail[9 * kMaxLanes];
  for (int k = 0; k < count; k += lanes) {
    for (int d = 0; d < 3; ++d)
      hn::StoreInterleaved3(hn::LoadU(tag, out + (first + d) * kSettleBatch + k),
                            hn::LoadU(tag, out + (first + 3 + d) * kSettleBatch + k),
                            hn::LoadU(tag, out + (first + 6 + d) * kSettleBatch + k), tag, by_coordinate[d]);
    const bool partial = count - k < lanes;
    double* to = partial ? tail : coords + 9 * k;
    for (int part = 0; part < 3; ++part)
      hn::StoreInterleaved3(hn::Load(tag, by_coordinate[0] + lanes * part), hn::Load(tag, by_coordinate[1] + lanes * part),
                            hn::Load(tag, by_coordinate[2] + lanes * part), tag, to + 3 * lanes * part);
    if (partial) std::copy(tail, tail + 9 * (count - k), coords + 9 * k);
  }
}

}  // namespace

SettleKernel SettleKernelFor() { return settle_batch; }
ConsecutiveLoad ConsecutiveLoadFor() { return load_consecutive; }
ConsecutiveStore ConsecutiveStoreFor() { return store_consecutive; }
ProjectionKernel ProjectionKernelFor() { return project_triangle_batch; }

}  // namespace HWY_NAMESPACE
}  // namespace vimd
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace vimd {
HWY_EXPORT(SettleKernelFor);
HWY_EXPORT(ProjectionKernelFor);
HWY_EXPORT(ConsecutiveLoadFor);
HWY_EXPORT(ConsecutiveStoreFor);
namespace simd {
SettleKernel settle_kernel() { return HWY_DYNAMIC_DISPATCH(SettleKernelFor)(); }
ProjectionKernel triangle_projection_kernel() { return HWY_DYNAMIC_DISPATCH(ProjectionKernelFor)(); }
ConsecutiveLoad consecutive_load() { return HWY_DYNAMIC_DISPATCH(ConsecutiveLoadFor)(); }
ConsecutiveStore consecutive_store() { return HWY_DYNAMIC_DISPATCH(ConsecutiveStoreFor)(); }
}  // namespace simd
}  // namespace vimd
#endif  // HWY_ONCE
