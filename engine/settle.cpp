// Rigid water: SETTLE for the position stage and the batched velocity projection, the special
// case of engine/shake_rattle_solve.cpp for clusters that are rigid isosceles triangles. The
// batches go through the SIMD kernels of engine/settle_kernels.cpp.
#include <algorithm>
#include <cmath>

#include "engine/constraint_layout.hpp"
#include "engine/settle_kernels.hpp"

namespace vimd::constraint_internals {

namespace {

// The lanes of a batch past `count` repeat the last molecule: the kernel computes full vectors and
// the extra lanes are ignored.
inline void pad_batch(double* in, int n_fields, int count) {
  for (int f = 0; f < n_fields; ++f)
    std::fill(in + f * kSettleBatch + count, in + (f + 1) * kSettleBatch, in[f * kSettleBatch + count - 1]);
}

// SETTLE (Miyamoto & Kollman, J. Comput. Chem. 13, 952 (1992)): the analytic solution of the
// same equations as solve_small_positions (displacements along the q_ref bonds, weighted by w)
// for a rigid isosceles triangle whose two base atoms have equal weights: the centre of mass
// stays, each atom keeps its height above the q_ref plane, and one in-plane rotation is fixed by
// the torque condition. In three parts: settle_prepare writes lane k of a batch's input (or
// finds SETTLE does not apply: q_ref off the constraints, unequal weights; or that q already
// satisfies them), the kernel (settle_kernels.cpp) rotates the whole batch, settle_finish checks
// and writes lane k's result. Where a part fails, q is untouched and Newton solves the cluster.
struct SettlePending {
  int cluster;
  Vec3 apex1, image_b, image_c;
};
enum class Settle { not_applicable, already_satisfied, prepared };

// The outcome of a triangle whose sides apex–h1, apex–h2 and base deviate by `deviation` (relative);
// false where one deviates by more than the tolerance (also NaN: a displacement too large for the
// triangle).
bool settle_outcome(const Layout& L, const Layout::Cluster& cl, const double deviation[3], int iterations,
                    double tolerance, ClusterOutcome& out) {
  const Layout::Triangle& t = L.triangles[cl.slot];
  const int position[3] = {t.ab, t.ac, t.bc};
  out = ClusterOutcome{};
  out.iterations = iterations;
  out.worst = cl.begin + position[0];
  for (int k = 0; k < 3; ++k) {
    if (!(deviation[k] <= tolerance)) return false;
    if (deviation[k] > out.deviation) out.deviation = deviation[k], out.worst = cl.begin + position[k];
  }
  return true;
}

Settle settle_prepare(const Layout& L, const Layout::Cluster& cl, const Coords& q_ref, const Coords& q,
                      const double* w, double tolerance, double* in, int k, SettlePending& pending,
                      ClusterOutcome& out) {
  const Layout::Triangle& t = L.triangles[cl.slot];
  if (!t.valid || w[t.h1] != w[t.h2] || !(w[t.apex] > 0) || !(w[t.h1] > 0)) return Settle::not_applicable;
  // Bond vectors from the apex, with the periodic image of q_ref (as solve_small_positions).
  const Vec3 raw_b = q_ref.col(t.h1) - q_ref.col(t.apex), raw_c = q_ref.col(t.h2) - q_ref.col(t.apex);
  const Vec3 b0 = L.box.minimum_image(raw_b), c0 = L.box.minimum_image(raw_c);
  if (!within(b0.squaredNorm(), t.d_side, tolerance) || !within(c0.squaredNorm(), t.d_side, tolerance) ||
      !within((c0 - b0).squaredNorm(), t.d_base, tolerance))
    return Settle::not_applicable;
  pending.image_b = b0 - raw_b;
  pending.image_c = c0 - raw_c;
  pending.apex1 = q.col(t.apex);
  const Vec3 b1_apex = q.col(t.h1) - pending.apex1 + pending.image_b;
  const Vec3 c1_apex = q.col(t.h2) - pending.apex1 + pending.image_c;
  // Already on the constraints: left exactly as it is, as Newton leaves it.
  if (within(b1_apex.squaredNorm(), t.d_side, tolerance) && within(c1_apex.squaredNorm(), t.d_side, tolerance) &&
      within((c1_apex - b1_apex).squaredNorm(), t.d_base, tolerance)) {
    const double deviation[3] = {relative_deviation(b1_apex.squaredNorm(), t.d_side),
                                 relative_deviation(c1_apex.squaredNorm(), t.d_side),
                                 relative_deviation((c1_apex - b1_apex).squaredNorm(), t.d_base)};
    if (settle_outcome(L, cl, deviation, 0, tolerance, out)) return Settle::already_satisfied;
  }
  const double base_weight = w[t.apex] / (w[t.h1] + 2 * w[t.apex]);  // m_H / M
  const double rc = 0.5 * t.d_base, height = std::sqrt(t.d_side * t.d_side - rc * rc);
  const double ra = 2 * base_weight * height;
  const double fields[kSettleInFields] = {b0.x(),      b0.y(),      b0.z(),      c0.x(),      c0.y(),
                                          c0.z(),      b1_apex.x(), b1_apex.y(), b1_apex.z(), c1_apex.x(),
                                          c1_apex.y(), c1_apex.z(), base_weight, ra,          height - ra,
                                          rc,          t.d_side,    t.d_base};
  for (int f = 0; f < kSettleInFields; ++f) in[f * kSettleBatch + k] = fields[f];
  return Settle::prepared;
}

bool settle_finish(const Layout& L, const Layout::Cluster& cl, const SettlePending& pending, const double* result,
                   int k, Coords& q, double tolerance, ClusterOutcome& out) {
  const Layout::Triangle& t = L.triangles[cl.slot];
  auto at = [&](int x) {
    return Vec3(result[x * kSettleBatch + k], result[(x + 1) * kSettleBatch + k], result[(x + 2) * kSettleBatch + k]);
  };
  const double deviation[3] = {result[kDeviationAB * kSettleBatch + k], result[kDeviationAC * kSettleBatch + k],
                               result[kDeviationBC * kSettleBatch + k]};
  if (!settle_outcome(L, cl, deviation, 1, tolerance, out)) return false;
  const Vec3 a3 = at(kAx), b3 = at(kBx), c3 = at(kCx);
  q.col(t.apex) = pending.apex1 + a3;
  q.col(t.h1) = pending.apex1 + b3 - pending.image_b;
  q.col(t.h2) = pending.apex1 + c3 - pending.image_c;
  return true;
}

// Lane k of a velocity-projection batch for a rigid triangle: its three bonds, rates and weight
// factors, in cluster order.
void projection_prepare(const Layout& L, const Layout::Cluster& cl, const Coords& q, const Coords& v,
                        const double* w, double* in, int k) {
  const int b = cl.begin;
  for (int a = 0; a < 3; ++a) {
    const Vec3 r = L.bond(q, b + a);
    for (int d = 0; d < 3; ++d) in[(kR0x + 3 * a + d) * kSettleBatch + k] = r[d];
    in[(kRate0 + a) * kSettleBatch + k] = r.dot(v.col(L.atom_i[b + a]) - v.col(L.atom_j[b + a]));
  }
  const int factor_field[3][3] = {{kC00, kC01, kC02}, {kC01, kC11, kC12}, {kC02, kC12, kC22}};
  for (int a = 0; a < 3; ++a)
    for (int c = a; c < 3; ++c) in[factor_field[a][c] * kSettleBatch + k] = L.coefficient(b + a, b + c, w);
}

// v ← v − W Gᵀ x with lane k's multipliers x (written to mu) and bonds.
void projection_finish(const Layout& L, const Layout::Cluster& cl, const double* in, const double* x, int k,
                       Coords& v, const double* w, double* mu) {
  const int b = cl.begin;
  for (int a = 0; a < 3; ++a) {
    const double xa = x[a * kSettleBatch + k];
    const Vec3 r(in[(kR0x + 3 * a) * kSettleBatch + k], in[(kR0y + 3 * a) * kSettleBatch + k],
                 in[(kR0z + 3 * a) * kSettleBatch + k]);
    L.move_along_bond(b + a, r, xa, w, v);
    mu[a] = xa;
  }
}

}  // namespace

Layout::Triangle rigid_triangle(const Layout& L, const Layout::Cluster& cl) {
  Layout::Triangle t;
  if (cl.size() != 3) return t;
  const int b = cl.begin;
  for (int apex_side = 0; apex_side < 3; ++apex_side) {
    // Sides k and m share the apex; side `apex_side` is the base, opposite to it.
    const int k = (apex_side + 1) % 3, m = (apex_side + 2) % 3;
    const int ki = L.atom_i[b + k], kj = L.atom_j[b + k], mi = L.atom_i[b + m], mj = L.atom_j[b + m];
    const int apex = (ki == mi || ki == mj) ? ki : (kj == mi || kj == mj) ? kj : -1;
    if (apex < 0) return t;  // not a triangle
    const int h1 = ki == apex ? kj : ki, h2 = mi == apex ? mj : mi;
    const int base_i = L.atom_i[b + apex_side], base_j = L.atom_j[b + apex_side];
    if (!((base_i == h1 && base_j == h2) || (base_i == h2 && base_j == h1)) || h1 == h2) return t;
    const double dk = L.length[b + k], dm = L.length[b + m], base = L.length[b + apex_side];
    if (std::abs(dk - dm) > 1e-12 * dk || !(base < 2 * dk)) continue;
    t.valid = true;
    t.apex = apex;
    t.h1 = h1;
    t.h2 = h2;
    t.ab = k;
    t.ac = m;
    t.bc = apex_side;
    t.d_side = dk;
    t.d_base = base;
    return t;
  }
  return t;
}

void settle_positions(const Layout& L, const Coords& q_ref, Coords& q, const double* w, double tolerance,
                      int max_iterations, Workspace& ws) {
  auto newton = [&](const Layout::Cluster& cl) {
    return solve_small_positions(L, cl, q_ref, q, w, tolerance, max_iterations, ws.lambda.data() + cl.begin);
  };
  const SettleKernel kernel = simd::settle_kernel();
  const int n_triangles = static_cast<int>(L.triangle_clusters.size());
  const int n_batches = (n_triangles + kSettleBatch - 1) / kSettleBatch;
#pragma omp parallel for schedule(guided) if (L.n_constraints() > kParallelMin)
  for (int batch = 0; batch < n_batches; ++batch) {
    double in[kSettleInFields * kSettleBatch], result[kSettleOutFields * kSettleBatch];
    SettlePending pending[kSettleBatch];
    int count = 0;
    for (int k = batch * kSettleBatch; k < std::min(n_triangles, (batch + 1) * kSettleBatch); ++k) {
      const int c = L.triangle_clusters[k];
      ClusterOutcome out;
      switch (settle_prepare(L, L.clusters[c], q_ref, q, w, tolerance, in, count, pending[count], out)) {
        case Settle::prepared: pending[count++].cluster = c; break;
        case Settle::already_satisfied: ws.record(c, out); break;
        case Settle::not_applicable: ws.record(c, newton(L.clusters[c])); break;
      }
    }
    if (count == 0) continue;
    pad_batch(in, kSettleInFields, count);
    kernel(count, in, result);
    for (int k = 0; k < count; ++k) {
      const auto& cl = L.clusters[pending[k].cluster];
      ClusterOutcome out;
      if (!settle_finish(L, cl, pending[k], result, k, q, tolerance, out)) out = newton(cl);
      ws.record(pending[k].cluster, out);
    }
  }
}

void project_triangle_velocities(const Layout& L, const Coords& q, Coords& v, const double* w, Workspace& ws) {
  const ProjectionKernel kernel = simd::triangle_projection_kernel();
  const int n_triangles = static_cast<int>(L.triangle_clusters.size());
  const int n_batches = (n_triangles + kSettleBatch - 1) / kSettleBatch;
#pragma omp for schedule(static) nowait
  for (int batch = 0; batch < n_batches; ++batch) {
    double in[kProjectionInFields * kSettleBatch], x[3 * kSettleBatch];
    const int first = batch * kSettleBatch, count = std::min(n_triangles - first, kSettleBatch);
    for (int k = 0; k < count; ++k)
      projection_prepare(L, L.clusters[L.triangle_clusters[first + k]], q, v, w, in, k);
    pad_batch(in, kProjectionInFields, count);
    kernel(count, in, x);
    for (int k = 0; k < count; ++k) {
      const int c = L.triangle_clusters[first + k];
      projection_finish(L, L.clusters[c], in, x, k, v, w, ws.delta.data() + L.clusters[c].begin);
      ws.singular[c] = false;
    }
  }
}

}  // namespace vimd::constraint_internals
