// Rigid water: SETTLE for the position stage and the batched velocity projection, the special
// case of engine/shake_rattle_solve.cpp for clusters that are rigid isosceles triangles. The
// batches go through the SIMD kernels of simd/settle_kernels.cpp.
#include <algorithm>
#include <cmath>

#include "engine/constraint_layout.hpp"
#include "simd/settle_kernels.hpp"

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
// the torque condition. The kernel (settle_kernels.cpp) takes a batch's positions as stored and
// also decides each molecule's outcome (SettleStatus: where SETTLE does not apply, where q already
// satisfies the constraints) and its step velocity; settle_positions copies them out. Where SETTLE
// does not apply or its result misses the tolerance, q is untouched and Newton solves the cluster.

void settle_prepare_constants(const Layout::Triangle& t, const double* w, double* in, int k) {
  in[kWeightA * kSettleBatch + k] = w[t.apex];
  in[kWeightB * kSettleBatch + k] = w[t.h1];
  in[kWeightC * kSettleBatch + k] = w[t.h2];
  in[kSide * kSettleBatch + k] = t.d_side;
  in[kBase * kSettleBatch + k] = t.d_base;
}

void settle_prepare(const Layout::Triangle& t, const Coords& q_ref, const Coords& q, const double* w, double* in,
                    int k) {
  const int atoms[3] = {t.apex, t.h1, t.h2};
  for (int a = 0; a < 3; ++a)
    for (int d = 0; d < 3; ++d) {
      in[(kRefAx + 3 * a + d) * kSettleBatch + k] = q_ref(d, atoms[a]);
      in[(kQAx + 3 * a + d) * kSettleBatch + k] = q(d, atoms[a]);
    }
  settle_prepare_constants(t, w, in, k);
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

namespace {

// The triangle of the k-th molecule of the batch starting at `first` of the triangle clusters.
const Layout::Triangle& batch_triangle(const Layout& L, int first, int k) {
  return L.triangles[L.clusters[L.triangle_clusters[first + k]].slot];
}

// What one settle_positions call works on, for its per-batch steps.
struct SettleCall {
  const Layout& L;
  const Coords& q_ref;
  Coords& q;
  const double* w;
  double tolerance;
  int max_iterations;
  Workspace& ws;
  const StepVelocity* velocity;
};

// A SETTLE batch's input: positions as stored where its molecules are consecutive atoms
// (first_atom ≥ 0), else gathered molecule by molecule.
void load_settle_batch(const SettleCall& call, ConsecutiveLoad load, int first, int count, int first_atom,
                       double* in) {
  const auto& [L, q_ref, q, w, tolerance, max_iterations, ws, velocity] = call;
  if (first_atom >= 0) {
    load(q_ref.data() + 3 * first_atom, count, in, kRefAx);
    load(q.data() + 3 * first_atom, count, in, kQAx);
    for (int k = 0; k < count; ++k) settle_prepare_constants(batch_triangle(L, first, k), w, in, k);
  } else {
    for (int k = 0; k < count; ++k) settle_prepare(batch_triangle(L, first, k), q_ref, q, w, in, k);
  }
  pad_batch(in, kSettleInFields, count);
}

// Lane k's outcome: Newton where SETTLE does not apply, else SETTLE's positions (where it rotated)
// and step velocity, unless `stored` (the whole batch's already went out in vectors).
void finish_settle_molecule(const SettleCall& call, int c, const double* result, int k, bool stored) {
  const auto& [L, q_ref, q, w, tolerance, max_iterations, ws, velocity] = call;
  const Layout::Cluster& cl = L.clusters[c];
  const auto status = static_cast<SettleStatus>(result[kStatus * kSettleBatch + k]);
  if (status == SettleStatus::newton) {
    ws.record(c, solve_small_positions(L, cl, q_ref, q, w, tolerance, max_iterations, ws.lambda.data() + cl.begin));
    if (velocity) L.set_step_velocity(c, q_ref, q, *velocity);
    return;
  }
  const Layout::Triangle& t = L.triangles[cl.slot];
  const int side_position[3] = {t.ab, t.ac, t.bc};
  const bool rotated = status == SettleStatus::rotated;
  ClusterOutcome out;
  out.iterations = rotated ? 1 : 0;
  out.worst = cl.begin + side_position[static_cast<int>(result[kWorstSide * kSettleBatch + k])];
  out.deviation = result[kDeviation * kSettleBatch + k];
  ws.record(c, out);
  if (stored) return;
  // Where q already satisfies the constraints it stays as it is; the velocities follow the same
  // formula as Layout::set_step_velocity, computed in the kernel's vectors.
  const int atoms[3] = {t.apex, t.h1, t.h2};
  for (int a = 0; a < 3; ++a)
    for (int d = 0; d < 3; ++d) {
      if (rotated) q(d, atoms[a]) = result[(kNewAx + 3 * a + d) * kSettleBatch + k];
      if (velocity) velocity->v(d, atoms[a]) = result[(kVelAx + 3 * a + d) * kSettleBatch + k];
    }
}

}  // namespace

void settle_positions(const Layout& L, const Coords& q_ref, Coords& q, const double* w, double tolerance,
                      int max_iterations, Workspace& ws, const StepVelocity* velocity) {
  const SettleCall call{L, q_ref, q, w, tolerance, max_iterations, ws, velocity};
  const SettleKernel kernel = simd::settle_kernel();
  const ConsecutiveLoad load = simd::consecutive_load();
  const ConsecutiveStore store = simd::consecutive_store();
  const SettleParams params{tolerance, {L.box.length[0], L.box.length[1], L.box.length[2]}, velocity != nullptr,
                            velocity ? 1 / velocity->h : 0};
  const int n_triangles = static_cast<int>(L.triangle_clusters.size());
  const int n_batches = (n_triangles + kSettleBatch - 1) / kSettleBatch;
  // Static: each thread writes the molecules whose atoms the integrator's per-atom loops (static
  // too, molecules in atom order) give it, so their cache lines stay on its core.
#pragma omp parallel for schedule(static) if (L.n_constraints() > kParallelMin)
  for (int batch = 0; batch < n_batches; ++batch) {
    double in[kSettleInFields * kSettleBatch], result[kSettleOutFields * kSettleBatch];
    const int first = batch * kSettleBatch, count = std::min(n_triangles - first, kSettleBatch);
    const int first_atom = L.consecutive_settle_batches[batch];
    load_settle_batch(call, load, first, count, first_atom, in);
    kernel(count, params, in, result);
    const double* status_of = result + kStatus * kSettleBatch;
    const bool whole = first_atom >= 0 && std::none_of(status_of, status_of + count, [](double s) {
                         return static_cast<SettleStatus>(s) == SettleStatus::newton;
                       });
    if (whole) {  // none left to Newton: positions (q itself where it stays) and velocities in vectors
      store(result, kNewAx, count, q.data() + 3 * first_atom);
      if (velocity) store(result, kVelAx, count, velocity->v.data() + 3 * first_atom);
    }
    for (int k = 0; k < count; ++k)
      finish_settle_molecule(call, L.triangle_clusters[first + k], result, k, whole);
  }
}

std::vector<int> consecutive_settle_batches(const Layout& L) {
  const int n_triangles = static_cast<int>(L.triangle_clusters.size());
  std::vector<int> first_atoms;
  for (int first = 0; first < n_triangles; first += kSettleBatch) {
    const int apex = L.triangles[L.clusters[L.triangle_clusters[first]].slot].apex;
    bool consecutive = true;
    for (int k = 0; consecutive && k < std::min(kSettleBatch, n_triangles - first); ++k) {
      const Layout::Triangle& t = L.triangles[L.clusters[L.triangle_clusters[first + k]].slot];
      consecutive = t.apex == apex + 3 * k && t.h1 == t.apex + 1 && t.h2 == t.apex + 2;
    }
    first_atoms.push_back(consecutive ? apex : -1);
  }
  return first_atoms;
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
