// The two constraint stages of SHAKE and RATTLE: the position solve (Newton on the multipliers,
// cluster by cluster) and the velocity projection onto the tangent space. Rigid water goes
// through engine/settle.cpp.
#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "engine/constraint_layout.hpp"
#include "engine/constraints.hpp"
#include "engine/errors.hpp"

namespace vimd {

using namespace constraint_internals;

namespace {

// Sparse clusters iterate with one factorisation of the symmetric S(q_ref) (a chord method);
// when the deviation shrinks by less than this factor per iteration they refactorise with the
// exact Newton matrix G(q) W G(q_ref)ᵀ.
constexpr double kChordRate = 0.25;

// The worst relative deviation of a cluster into out, from each bond's r² (squared_length(p) for
// position p).
template <class SquaredLength>
void find_worst_deviation(const Layout& L, const Layout::Cluster& cl, SquaredLength squared_length,
                          ClusterOutcome& out) {
  out.deviation = 0;
  out.worst = cl.begin;
  for (int p = cl.begin; p < cl.end; ++p) {
    const double dev = relative_deviation(squared_length(p), L.length[p]);
    if (dev > out.deviation) out.deviation = dev, out.worst = p;
  }
}

// The stopping tests of a cluster's Newton iteration once its bonds are measured (inside: every
// bond within the tolerance window; finite: every r² finite). True when the iteration stops,
// converged, diverged or out of iterations, with the outcome in out.
template <class SquaredLength>
bool newton_stops(const Layout& L, const Layout::Cluster& cl, bool inside, bool finite, double tolerance,
                  int max_iterations, SquaredLength squared_length, ClusterOutcome& out) {
  if (inside) {
    find_worst_deviation(L, cl, squared_length, out);
    if (out.deviation <= tolerance) return true;
  }
  if (!finite) {
    out.deviation = std::numeric_limits<double>::quiet_NaN();
    out.failed = true;
    return true;
  }
  if (out.iterations >= max_iterations) {
    find_worst_deviation(L, cl, squared_length, out);
    out.failed = true;
    return true;
  }
  return false;
}

// Bond vectors r = q_i − q_j + image and g_a of one cluster at q (cluster order). Returns whether
// every bond is within the tolerance window; sets finite and size = max |g_a| / d_a² (≈ the
// worst relative deviation, to judge the convergence rate).
bool measure(const Layout& L, const Layout::Cluster& cl, const Coords& q, const Coords& image, double tolerance,
             Coords& r, Eigen::VectorXd& g, bool& finite, double& size) {
  bool inside = true;
  finite = true;
  size = 0;
  for (int p = cl.begin; p < cl.end; ++p) {
    r.col(p) = q.col(L.atom_i[p]) - q.col(L.atom_j[p]) + image.col(p);
    const double r2 = r.col(p).squaredNorm(), d = L.length[p];
    g[p] = 0.5 * (r2 - d * d);
    inside = inside && within(r2, d, tolerance);
    finite = finite && std::isfinite(r2);
    size = std::max(size, std::abs(g[p]) / (d * d));
  }
  return inside;
}

}  // namespace

// Newton for a cluster of at most three constraints (rigid water), entirely on the stack:
// J = G(q) W G(q_ref)ᵀ is rebuilt every iteration (quadratic convergence) and inverted in
// closed form; unused rows of the padded 3×3 system are the identity.
ClusterOutcome constraint_internals::solve_small_positions(const Layout& L, const Layout::Cluster& cl,
                                                           const Coords& q_ref, Coords& q, const double* w,
                                                           double tolerance, int max_iterations, double* lambda) {
  const int b = cl.begin, m = cl.size();
  Vec3 r_ref[kSmallMax], r[kSmallMax], image[kSmallMax];
  Eigen::Matrix3d coef;
  for (int a = 0; a < m; ++a) {
    // Positions are never wrapped within a run, so a bond has the same periodic image at q_ref,
    // q and every iterate (corrections are far below half a box): the minimum image is taken
    // once, r = q_i − q_j + image.
    const Vec3 raw = q_ref.col(L.atom_i[b + a]) - q_ref.col(L.atom_j[b + a]);
    r_ref[a] = L.box.minimum_image(raw);
    image[a] = r_ref[a] - raw;
    lambda[a] = 0;
    for (int c = 0; c < m; ++c) coef(a, c) = L.coefficient(b + a, b + c, w);
  }
  ClusterOutcome out;
  double r2[kSmallMax];
  for (;;) {
    Eigen::Vector3d g = Eigen::Vector3d::Zero();
    bool inside = true, finite = true;
    for (int a = 0; a < m; ++a) {
      r[a] = q.col(L.atom_i[b + a]) - q.col(L.atom_j[b + a]) + image[a];
      r2[a] = r[a].squaredNorm();
      const double d = L.length[b + a];
      g[a] = 0.5 * (r2[a] - d * d);
      inside = inside && within(r2[a], d, tolerance);
      finite = finite && std::isfinite(r2[a]);
    }
    if (newton_stops(L, cl, inside, finite, tolerance, max_iterations, [&](int p) { return r2[p - b]; }, out))
      return out;
    Eigen::Matrix3d J = Eigen::Matrix3d::Identity();
    for (int a = 0; a < m; ++a)
      for (int c = 0; c < m; ++c) J(a, c) = coef(a, c) * r[a].dot(r_ref[c]);
    const Eigen::Vector3d delta = -(J.inverse() * g);
    for (int a = 0; a < m; ++a) {
      L.move_along_bond(b + a, r_ref[a], -delta[a], w, q);
      lambda[a] += delta[a];
    }
    ++out.iterations;
  }
}

int Constraints::solve_positions(const Coords& q_ref, Coords& q, const Eigen::VectorXd& weights, double tolerance,
                                 long step, int max_iterations, Eigen::VectorXd* lambda_out,
                                 double* max_deviation_out, const StepVelocity* velocity) const {
  if (lambda_out) lambda_out->setZero(size());
  if (max_deviation_out) *max_deviation_out = 0;
  if (empty()) return 0;
  if (!(tolerance > 0)) throw std::invalid_argument("constraint tolerance must be positive");
  const Layout& L = *layout_;
  L.check_coords(q_ref, "q_ref");
  L.check_coords(q, "q");
  const double* w = L.weights(weights);
  Workspace& ws = *work_;
  ClusterFactors& f = ws.factorization.factors();
  const int nc = static_cast<int>(L.clusters.size());

  // Dense and sparse clusters: Newton on λ with the cluster's factorisation in the workspace.
  auto solve_dynamic = [&](const Layout::Cluster& cl) {
    const int b = cl.begin, m = cl.size();
    ClusterOutcome out;
    double* delta = ws.delta.data() + b;
    for (int p = b; p < b + m; ++p) {
      // As in the small kernel: one periodic image per bond for q_ref, q and every iterate.
      const Vec3 raw = q_ref.col(L.atom_i[p]) - q_ref.col(L.atom_j[p]);
      ws.r_ref.col(p) = L.box.minimum_image(raw);
      ws.image.col(p) = ws.r_ref.col(p) - raw;
      ws.lambda[p] = 0;
    }
    auto squared_length = [&](int p) { return ws.r_cur.col(p).squaredNorm(); };
    double previous = std::numeric_limits<double>::infinity();
    for (;;) {
      bool finite;
      double size;
      const bool inside = measure(L, cl, q, ws.image, tolerance, ws.r_cur, ws.g, finite, size);
      if (newton_stops(L, cl, inside, finite, tolerance, max_iterations, squared_length, out)) return out;
      // The Jacobian of g(q + W G(q_ref)ᵀ λ) is G(q) W G(q_ref)ᵀ. Dense clusters use it every
      // iteration; sparse ones start from the symmetric S(q_ref) (one cheap LDLᵀ) and switch to
      // the exact matrix only when that converges slowly.
      const bool chord_start = cl.kind == Kind::Sparse && out.iterations == 0;
      const bool refresh = cl.kind == Kind::Dense || chord_start || size > kChordRate * previous;
      if (refresh && !f.factor(cl, chord_start ? ws.r_ref : ws.r_cur, ws.r_ref, w, chord_start)) {
        find_worst_deviation(L, cl, squared_length, out);
        out.failed = out.singular = true;
        return out;
      }
      for (int a = 0; a < m; ++a) delta[a] = -ws.g[b + a];
      f.solve(cl, delta);
      for (int a = 0; a < m; ++a) {
        L.move_along_bond(b + a, ws.r_ref.col(b + a), -delta[a], w, q);
        ws.lambda[b + a] += delta[a];
      }
      previous = size;
      ++out.iterations;
    }
  };

  // SETTLE gives positions, not multipliers: only where nobody asks for them. Every other
  // cluster goes through Newton.
  const bool by_settle = !lambda_out && !L.triangle_clusters.empty();
  if (by_settle) settle_positions(L, q_ref, q, w, tolerance, max_iterations, ws, velocity);
  const int n_newton = by_settle ? static_cast<int>(L.other_clusters.size()) : nc;
#pragma omp parallel for schedule(guided) if (size() > kParallelMin && n_newton > 1)
  for (int k = 0; k < n_newton; ++k) {
    const int c = by_settle ? L.other_clusters[k] : k;
    const auto& cl = L.clusters[c];
    ws.record(c, cl.kind == Kind::Small ? solve_small_positions(L, cl, q_ref, q, w, tolerance, max_iterations,
                                                                ws.lambda.data() + cl.begin)
                                        : solve_dynamic(cl));
    if (velocity) L.set_step_velocity(c, q_ref, q, *velocity);
  }

  // Report the failed cluster that is furthest off; a diverged (NaN) one first.
  auto worse = [&](int c, int than) {
    if (than < 0) return true;
    if (std::isnan(ws.deviation[than])) return false;
    return std::isnan(ws.deviation[c]) || ws.deviation[c] > ws.deviation[than];
  };
  int iterations = 0, failed = -1;
  for (int c = 0; c < nc; ++c) {
    iterations = std::max(iterations, ws.iterations[c]);
    if (ws.failed[c] && worse(c, failed)) failed = c;
  }
  if (failed >= 0) {
    const double dev = ws.deviation[failed];
    std::string detail = "worst " + L.describe(ws.worst[failed]);
    if (ws.singular[failed])
      detail += ": the constraint matrix is singular (linearly dependent constraints)";
    else if (std::isnan(dev))
      detail += ": the iteration diverged (non-finite deviation)";
    else
      detail += " deviates from its length by " + format_number(dev) + " relative (tolerance " +
                format_number(tolerance) + ")";
    detail += "; a smaller time step usually helps";
    throw ConvergenceError("constraint solver", step, ws.iterations[failed], dev, detail);
  }
  if (lambda_out)
    for (int p = 0; p < size(); ++p) (*lambda_out)[L.original[p]] = ws.lambda[p];
  if (max_deviation_out) *max_deviation_out = *std::max_element(ws.deviation.begin(), ws.deviation.end());
  return iterations;
}

void Constraints::project_velocities(const Coords& q, Coords& v, const Eigen::VectorXd& weights,
                                     Eigen::VectorXd* mu_out) const {
  if (mu_out) mu_out->setZero(size());
  if (empty()) return;
  const Layout& L = *layout_;
  L.check_coords(q, "q");
  L.check_coords(v, "v");
  const double* w = L.weights(weights);
  Workspace& ws = *work_;
  ClusterFactors& f = ws.factorization.factors();
  const int nc = static_cast<int>(L.clusters.size());
#pragma omp parallel if (size() > kParallelMin)
  {
    // Rigid triangles in SIMD batches; every other cluster one by one.
    project_triangle_velocities(L, q, v, w, ws);
#pragma omp for schedule(guided)
    for (int c = 0; c < nc; ++c) {
      const auto& cl = L.clusters[c];
      if (L.is_triangle(cl)) continue;  // done above
      const int b = cl.begin, m = cl.size();
      double* mu = ws.delta.data() + b;
      for (int a = 0; a < m; ++a) {
        const int i = L.atom_i[b + a], j = L.atom_j[b + a];
        ws.r_cur.col(b + a) = L.bond(q, b + a);
        mu[a] = ws.r_cur.col(b + a).dot(v.col(i) - v.col(j));
      }
      ws.singular[c] = !f.factor(cl, ws.r_cur, ws.r_cur, w, true);
      if (ws.singular[c]) continue;
      f.solve(cl, mu);
      for (int a = 0; a < m; ++a) L.move_along_bond(b + a, ws.r_cur.col(b + a), mu[a], w, v);
    }
  }
  for (int c = 0; c < nc; ++c)
    if (ws.singular[c])
      L.throw_singular(c);
  if (mu_out)
    for (int p = 0; p < size(); ++p) (*mu_out)[L.original[p]] = ws.delta[p];
}

}  // namespace vimd
