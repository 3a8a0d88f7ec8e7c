#include "engine/constraints.hpp"

#include <Eigen/LU>
#include <Eigen/OrderingMethods>
#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>
#include <Eigen/SparseLU>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <utility>

#include "engine/errors.hpp"
#include "engine/settle_kernels.hpp"

namespace vimd {

namespace {

// Clusters of up to three constraints (rigid water, single bonds) use padded 3×3 kernels with
// everything on the stack; up to kDenseMax a dense LU; beyond that (whole chains) a sparse one.
constexpr int kSmallMax = 3;
constexpr int kDenseMax = 16;
// Sparse clusters iterate with one factorisation of the symmetric S(q_ref) (a chord method);
// when the deviation shrinks by less than this factor per iteration they refactorise with the
// exact Newton matrix G(q) W G(q_ref)ᵀ.
constexpr double kChordRate = 0.25;
// OpenMP only pays off above this many constraints.
constexpr int kParallelMin = 1000;

enum class Kind { Small, Dense, Sparse };

// | |r| − d | / d from r². The cancellation in |r| − d costs nothing that matters: its absolute
// error is a few ulp of d, i.e. 1e-16, far below any usable tolerance.
inline double relative_deviation(double r2, double d) { return std::abs(std::sqrt(r2) - d) / d; }

// The lanes of a batch past `count` repeat the last molecule: the kernel computes full vectors and
// the extra lanes are ignored.
inline void pad_batch(double* in, int n_fields, int count) {
  for (int f = 0; f < n_fields; ++f)
    std::fill(in + f * kSettleBatch + count, in + (f + 1) * kSettleBatch, in[f * kSettleBatch + count - 1]);
}

// r² inside [(d(1 − tol))², (d(1 + tol))²] ⇔ relative deviation ≤ tol (up to rounding): the
// iterations test this, without a square root or division, and compute the exact deviation only
// once every bond of a cluster passes it.
inline bool within(double r2, double d, double tolerance) {
  const double lo = d * (1 - tolerance), hi = d * (1 + tolerance);
  return r2 >= lo * lo && r2 <= hi * hi;
}

// max over k of f(k); NaN if any f(k) is NaN (so a blown-up state is never reported as fine).
template <class F>
double parallel_max(int n, F f) {
  double result = 0;
#pragma omp parallel if (n > kParallelMin)
  {
    double local = 0;
#pragma omp for schedule(static) nowait
    for (int k = 0; k < n; ++k) {
      const double x = f(k);
      if (x > local || std::isnan(x)) local = std::isnan(local) ? local : x;
    }
#pragma omp critical(vimd_constraints_max)
    if (local > result || std::isnan(local)) result = std::isnan(result) ? result : local;
  }
  return result;
}

// How one cluster's position solve ended.
struct ClusterOutcome {
  int iterations = 0;
  int worst = 0;  // position of the worst constraint
  double deviation = 0;
  bool failed = false, singular = false;
};

std::string format_number(double x) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3e", x);
  return buf;
}

}  // namespace

struct Constraints::Layout {
  struct Cluster {
    int begin, end;  // range in the cluster-ordered arrays below
    Kind kind;
    int slot;  // index into the small or dynamic storage of a Factorization
    int size() const { return end - begin; }
  };
  // Two constraints a ≠ b (local indices) that share `atom`; sign = s_a(atom) s_b(atom) with
  // s = +1 at the constraint's first atom and −1 at its second.
  struct Coupling {
    int a, b, atom;
    double sign;
  };
  struct Dynamic {
    std::vector<Coupling> couplings;
    // Sparse clusters: the structure of S (values unused) and where each entry lives in it.
    Eigen::SparseMatrix<double> pattern;
    std::vector<int> diagonal_position, coupling_position;
  };

  Box box;
  int n_atoms = 0;
  // The constraint list reordered so that every cluster is contiguous.
  std::vector<int> atom_i, atom_j, original;
  std::vector<double> length;
  std::vector<Cluster> clusters;
  std::vector<Dynamic> dynamic;
  int n_small = 0;
  Eigen::VectorXd ones;  // the weights when the caller passes none
  // Rigid isosceles triangles (3-site water) among the small clusters, by Cluster::slot: apex atom
  // (O), the two others (H), and where each side sits in the cluster (ab = apex-h1, ac, bc).
  struct Triangle {
    bool valid = false;
    int apex, h1, h2;
    int ab, ac, bc;
    double d_side, d_base;
  };
  std::vector<Triangle> triangles;
  std::vector<int> triangle_clusters;  // the clusters with a valid triangle, in order
  // The atoms of each cluster, once each: those of cluster c at [atom_begin[c], atom_begin[c + 1]).
  std::vector<int> atoms, atom_begin;

  Vec3 bond(const Coords& q, int p) const { return box.minimum_image(q.col(atom_i[p]) - q.col(atom_j[p])); }
  // x ← x − s W Gᵀ_p for constraint p with bond vector r: its atoms move by ∓ s w along r.
  void move_along_bond(int p, const Vec3& r, double s, const double* w, Coords& x) const {
    x.col(atom_i[p]) -= (w[atom_i[p]] * s) * r;
    x.col(atom_j[p]) += (w[atom_j[p]] * s) * r;
  }
  // Entry factor of S = G W Gᵀ for positions p, r (p == r gives w_i + w_j).
  double coefficient(int p, int r, const double* w) const {
    double c = 0;
    if (atom_i[p] == atom_i[r]) c += w[atom_i[p]];
    if (atom_i[p] == atom_j[r]) c -= w[atom_i[p]];
    if (atom_j[p] == atom_i[r]) c -= w[atom_j[p]];
    if (atom_j[p] == atom_j[r]) c += w[atom_j[p]];
    return c;
  }
  const double* weights(const Eigen::VectorXd& w) const {
    if (w.size() == 0) return ones.data();
    if (w.size() != n_atoms)
      throw std::invalid_argument("constraint weights: " + std::to_string(w.size()) + " values for " +
                                  std::to_string(n_atoms) + " atoms");
    return w.data();
  }
  void check_coords(const Coords& x, const char* what) const {
    if (x.cols() != n_atoms)
      throw std::invalid_argument(std::string("constraints: ") + what + " has " + std::to_string(x.cols()) +
                                  " atoms, the system " + std::to_string(n_atoms));
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
  Settle settle_prepare(const Cluster& cl, const Coords& q_ref, const Coords& q, const double* w, double tolerance,
                        double* in, int k, SettlePending& pending, ClusterOutcome& out) const {
    const Triangle& t = triangles[cl.slot];
    if (!t.valid || w[t.h1] != w[t.h2] || !(w[t.apex] > 0) || !(w[t.h1] > 0)) return Settle::not_applicable;
    // Bond vectors from the apex, with the periodic image of q_ref (as solve_small_positions).
    const Vec3 raw_b = q_ref.col(t.h1) - q_ref.col(t.apex), raw_c = q_ref.col(t.h2) - q_ref.col(t.apex);
    const Vec3 b0 = box.minimum_image(raw_b), c0 = box.minimum_image(raw_c);
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
        within((c1_apex - b1_apex).squaredNorm(), t.d_base, tolerance) &&
        settle_outcome(cl, b1_apex, c1_apex, 0, tolerance, out))
      return Settle::already_satisfied;
    const double base_weight = w[t.apex] / (w[t.h1] + 2 * w[t.apex]);  // m_H / M
    const double rc = 0.5 * t.d_base, height = std::sqrt(t.d_side * t.d_side - rc * rc);
    const double ra = 2 * base_weight * height;
    const double fields[kSettleInFields] = {b0.x(),      b0.y(),      b0.z(),      c0.x(),  c0.y(),
                                            c0.z(),      b1_apex.x(), b1_apex.y(), b1_apex.z(), c1_apex.x(),
                                            c1_apex.y(), c1_apex.z(), base_weight, ra,     height - ra,
                                            rc};
    for (int f = 0; f < kSettleInFields; ++f) in[f * kSettleBatch + k] = fields[f];
    return Settle::prepared;
  }
  bool settle_finish(const Cluster& cl, const SettlePending& pending, const double* result, int k, Coords& q,
                     double tolerance, ClusterOutcome& out) const {
    const Triangle& t = triangles[cl.slot];
    auto at = [&](int x) { return Vec3(result[x * kSettleBatch + k], result[(x + 1) * kSettleBatch + k],
                                       result[(x + 2) * kSettleBatch + k]); };
    const Vec3 a3 = at(kAx), b3 = at(kBx), c3 = at(kCx);
    if (!settle_outcome(cl, b3 - a3, c3 - a3, 1, tolerance, out)) return false;
    q.col(t.apex) = pending.apex1 + a3;
    q.col(t.h1) = pending.apex1 + b3 - pending.image_b;
    q.col(t.h2) = pending.apex1 + c3 - pending.image_c;
    return true;
  }
  // The outcome of a triangle whose apex→h1 and apex→h2 bonds are ab and ac; false where a side
  // deviates by more than the tolerance (also NaN: a displacement too large for the triangle).
  bool settle_outcome(const Cluster& cl, const Vec3& ab, const Vec3& ac, int iterations, double tolerance,
                      ClusterOutcome& out) const {
    const Triangle& t = triangles[cl.slot];
    const int position[3] = {t.ab, t.ac, t.bc};
    const double deviation[3] = {relative_deviation(ab.squaredNorm(), t.d_side),
                                 relative_deviation(ac.squaredNorm(), t.d_side),
                                 relative_deviation((ac - ab).squaredNorm(), t.d_base)};
    out = ClusterOutcome{};
    out.iterations = iterations;
    out.worst = cl.begin + position[0];
    for (int k = 0; k < 3; ++k) {
      if (!(deviation[k] <= tolerance)) return false;
      if (deviation[k] > out.deviation) out.deviation = deviation[k], out.worst = cl.begin + position[k];
    }
    return true;
  }

  // Newton for a cluster of at most three constraints (rigid water), entirely on the stack:
  // J = G(q) W G(q_ref)ᵀ is rebuilt every iteration (quadratic convergence) and inverted in
  // closed form; unused rows of the padded 3×3 system are the identity.
  ClusterOutcome solve_small_positions(const Cluster& cl, const Coords& q_ref, Coords& q, const double* w,
                                       double tolerance, int max_iterations, double* lambda) const {
    const int b = cl.begin, m = cl.size();
    Vec3 r_ref[kSmallMax], r[kSmallMax], image[kSmallMax];
    Eigen::Matrix3d coef;
    for (int a = 0; a < m; ++a) {
      // Positions are never wrapped within a run, so a bond has the same periodic image at q_ref,
      // q and every iterate (corrections are far below half a box): the minimum image is taken
      // once, r = q_i − q_j + image.
      const Vec3 raw = q_ref.col(atom_i[b + a]) - q_ref.col(atom_j[b + a]);
      r_ref[a] = box.minimum_image(raw);
      image[a] = r_ref[a] - raw;
      lambda[a] = 0;
      for (int c = 0; c < m; ++c) coef(a, c) = coefficient(b + a, b + c, w);
    }
    ClusterOutcome out;
    double r2[kSmallMax];
    auto exact_deviation = [&] {
      out.deviation = 0;
      out.worst = b;
      for (int a = 0; a < m; ++a) {
        const double dev = relative_deviation(r2[a], length[b + a]);
        if (dev > out.deviation) out.deviation = dev, out.worst = b + a;
      }
    };
    for (;;) {
      Eigen::Vector3d g = Eigen::Vector3d::Zero();
      bool inside = true, finite = true;
      for (int a = 0; a < m; ++a) {
        r[a] = q.col(atom_i[b + a]) - q.col(atom_j[b + a]) + image[a];
        r2[a] = r[a].squaredNorm();
        const double d = length[b + a];
        g[a] = 0.5 * (r2[a] - d * d);
        inside = inside && within(r2[a], d, tolerance);
        finite = finite && std::isfinite(r2[a]);
      }
      if (inside) {
        exact_deviation();
        if (out.deviation <= tolerance) return out;
      }
      if (!finite) {
        out.deviation = std::numeric_limits<double>::quiet_NaN();
        out.failed = true;
        return out;
      }
      if (out.iterations >= max_iterations) {
        exact_deviation();
        out.failed = true;
        return out;
      }
      Eigen::Matrix3d J = Eigen::Matrix3d::Identity();
      for (int a = 0; a < m; ++a)
        for (int c = 0; c < m; ++c) J(a, c) = coef(a, c) * r[a].dot(r_ref[c]);
      const Eigen::Vector3d delta = -(J.inverse() * g);
      for (int a = 0; a < m; ++a) {
        move_along_bond(b + a, r_ref[a], -delta[a], w, q);
        lambda[a] += delta[a];
      }
      ++out.iterations;
    }
  }

  // Lane k of a velocity-projection batch (project_triangle_batch) for a rigid triangle: its three
  // bonds, rates and weight factors, in cluster order.
  void projection_prepare(const Cluster& cl, const Coords& q, const Coords& v, const double* w, double* in,
                          int k) const {
    const int b = cl.begin;
    for (int a = 0; a < 3; ++a) {
      const Vec3 r = bond(q, b + a);
      for (int d = 0; d < 3; ++d) in[(kR0x + 3 * a + d) * kSettleBatch + k] = r[d];
      in[(kRate0 + a) * kSettleBatch + k] = r.dot(v.col(atom_i[b + a]) - v.col(atom_j[b + a]));
    }
    const int factor_field[3][3] = {{kC00, kC01, kC02}, {kC01, kC11, kC12}, {kC02, kC12, kC22}};
    for (int a = 0; a < 3; ++a)
      for (int c = a; c < 3; ++c) in[factor_field[a][c] * kSettleBatch + k] = coefficient(b + a, b + c, w);
  }
  // v ← v − W Gᵀ x with lane k's multipliers x (written to mu) and bonds.
  void projection_finish(const Cluster& cl, const double* in, const double* x, int k, Coords& v, const double* w,
                         double* mu) const {
    const int b = cl.begin;
    for (int a = 0; a < 3; ++a) {
      const double xa = x[a * kSettleBatch + k];
      const Vec3 r(in[(kR0x + 3 * a) * kSettleBatch + k], in[(kR0y + 3 * a) * kSettleBatch + k],
                   in[(kR0z + 3 * a) * kSettleBatch + k]);
      move_along_bond(b + a, r, xa, w, v);
      mu[a] = xa;
    }
  }

  // v ← v − W Gᵀ S⁻¹ G v for a cluster of at most three constraints, on the stack.
  void project_small_velocities(const Cluster& cl, const Coords& q, Coords& v, const double* w, double* mu) const {
    const int b = cl.begin, m = cl.size();
    Vec3 r[kSmallMax];
    Eigen::Vector3d rate = Eigen::Vector3d::Zero();
    for (int a = 0; a < m; ++a) {
      r[a] = bond(q, b + a);
      rate[a] = r[a].dot(v.col(atom_i[b + a]) - v.col(atom_j[b + a]));
    }
    Eigen::Matrix3d S = Eigen::Matrix3d::Identity();
    for (int a = 0; a < m; ++a)
      for (int c = 0; c < m; ++c) S(a, c) = coefficient(b + a, b + c, w) * r[a].dot(r[c]);
    const Eigen::Vector3d x = S.inverse() * rate;
    for (int a = 0; a < m; ++a) {
      move_along_bond(b + a, r[a], x[a], w, v);
      mu[a] = x[a];
    }
  }

  std::string describe(int p) const {
    return "constraint " + std::to_string(original[p] + 1) + " (atoms " + std::to_string(atom_i[p] + 1) + "-" +
           std::to_string(atom_j[p] + 1) + ", 1-based)";
  }
  [[noreturn]] void throw_singular(int cluster) const {
    throw std::runtime_error("constraints: the matrix G W Gᵀ of the cluster with " + describe(clusters[cluster].begin) +
                             " is singular (the constraints are linearly dependent at these positions)");
  }
};

namespace {

// SimplicialLDLT on a pattern that the Layout has already ordered for low fill, refactorised
// through Eigen's factorize_preordered: the public factorize() copies the matrix (a heap
// allocation) on every call, which a step must not do.
class PreorderedLDLT
    : public Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>, Eigen::Upper, Eigen::NaturalOrdering<int>> {
 public:
  // `full` holds both triangles; only the upper one is read.
  void refactorize(const Eigen::SparseMatrix<double>& full) { factorize_preordered<true>(full); }
};

}  // namespace

struct Constraints::Factorization::Impl {
  struct Dynamic {
    Eigen::MatrixXd dense_matrix;
    Eigen::PartialPivLU<Eigen::MatrixXd> dense;
    Eigen::SparseMatrix<double> matrix;
    PreorderedLDLT ldlt;
    Eigen::SparseLU<Eigen::SparseMatrix<double>, Eigen::COLAMDOrdering<int>> lu;
    bool ldlt_analysed = false, lu_analysed = false;
    bool symmetric = true;  // which of ldlt / lu holds the current factorisation
    Eigen::VectorXd rhs, x;
  };

  std::shared_ptr<const Layout> layout;
  // S⁻¹ of each small cluster in closed form (Eigen's 3×3 cofactor inverse), a third of the cost
  // of a pivoted LU and its solves; a degenerate (collinear) triangle gives non-finite values as
  // the LU did.
  std::vector<Eigen::Matrix3d> small_inverse;
  std::unique_ptr<Dynamic[]> dynamic;  // SparseLU is not movable, so no std::vector
  Coords r_left, r_right;
  bool factorized = false;
  bool symmetric = false;  // factorised with q_left = q_right: r_left holds G's bond vectors

  // Sizes the storage for a layout once; later calls with the same layout are free.
  void bind(const std::shared_ptr<const Layout>& l) {
    if (layout == l) return;
    layout = l;
    factorized = false;
    small_inverse.assign(l->n_small, Eigen::Matrix3d::Identity());
    dynamic = std::make_unique<Dynamic[]>(l->dynamic.size());
    for (const auto& cl : l->clusters) {
      if (cl.kind == Kind::Small) continue;
      Dynamic& d = dynamic[cl.slot];
      const int m = cl.size();
      if (cl.kind == Kind::Dense) {
        d.dense_matrix.resize(m, m);
        d.dense = Eigen::PartialPivLU<Eigen::MatrixXd>(m);
      } else {
        d.matrix = l->dynamic[cl.slot].pattern;
      }
      d.rhs.resize(m);
      d.x.resize(m);
    }
    r_left.resize(3, l->atom_i.size());
    r_right.resize(3, l->atom_i.size());
  }

  // Factorises S = G_left W G_rightᵀ of one cluster from its bond vectors (columns of the
  // cluster-ordered arrays). False if a sparse factorisation finds S singular.
  bool factor(const Layout::Cluster& cl, const Coords& rl, const Coords& rr, const double* w, bool symmetric) {
    const Layout& L = *layout;
    const int b = cl.begin, m = cl.size();
    if (cl.kind == Kind::Small) {
      Eigen::Matrix3d s = Eigen::Matrix3d::Identity();  // unused rows stay identity
      for (int a = 0; a < m; ++a)
        for (int c = 0; c < m; ++c) s(a, c) = L.coefficient(b + a, b + c, w) * rl.col(b + a).dot(rr.col(b + c));
      small_inverse[cl.slot] = s.inverse();
      return true;
    }
    Dynamic& d = dynamic[cl.slot];
    const Layout::Dynamic& ld = L.dynamic[cl.slot];
    if (cl.kind == Kind::Dense) {
      d.dense_matrix.setZero();
      for (int a = 0; a < m; ++a)
        d.dense_matrix(a, a) = L.coefficient(b + a, b + a, w) * rl.col(b + a).dot(rr.col(b + a));
      for (const auto& e : ld.couplings)
        d.dense_matrix(e.a, e.b) = e.sign * w[e.atom] * rl.col(b + e.a).dot(rr.col(b + e.b));
      d.dense.compute(d.dense_matrix);
      d.symmetric = symmetric;
      return true;
    }
    double* values = d.matrix.valuePtr();
    for (int a = 0; a < m; ++a)
      values[ld.diagonal_position[a]] = L.coefficient(b + a, b + a, w) * rl.col(b + a).dot(rr.col(b + a));
    for (std::size_t k = 0; k < ld.couplings.size(); ++k) {
      const auto& e = ld.couplings[k];
      values[ld.coupling_position[k]] = e.sign * w[e.atom] * rl.col(b + e.a).dot(rr.col(b + e.b));
    }
    d.symmetric = symmetric;
    if (symmetric) {
      if (!d.ldlt_analysed) d.ldlt.analyzePattern(d.matrix), d.ldlt_analysed = true;
      d.ldlt.refactorize(d.matrix);
      return d.ldlt.info() == Eigen::Success;
    }
    if (!d.lu_analysed) d.lu.analyzePattern(d.matrix), d.lu_analysed = true;
    d.lu.factorize(d.matrix);
    return d.lu.info() == Eigen::Success;
  }

  // x ← S⁻¹ x for one cluster; x points at the cluster's m values.
  void solve(const Layout::Cluster& cl, double* x) {
    const int m = cl.size();
    if (cl.kind == Kind::Small) {
      // Loops of fixed length: with m as their bound, g++ made them memcpy calls, ~1 % of a vi run.
      Eigen::Vector3d rhs;
      for (int a = 0; a < kSmallMax; ++a) rhs[a] = a < m ? x[a] : 0.0;
      const Eigen::Vector3d sol = small_inverse[cl.slot] * rhs;
      for (int a = 0; a < kSmallMax; ++a)
        if (a < m) x[a] = sol[a];
      return;
    }
    Dynamic& d = dynamic[cl.slot];
    d.rhs = Eigen::Map<const Eigen::VectorXd>(x, m);
    if (cl.kind == Kind::Dense)
      d.x = d.dense.solve(d.rhs);
    else if (d.symmetric)
      d.x = d.ldlt.solve(d.rhs);
    else
      d.x = d.lu.solve(d.rhs);
    Eigen::Map<Eigen::VectorXd>(x, m) = d.x;
  }
};

struct Constraints::Workspace {
  Factorization factorization;  // solvers of the dense and sparse clusters
  Coords r_ref, r_cur;          // bond vectors, cluster order
  Coords image;                 // per bond: minimum_image(q_i − q_j) − (q_i − q_j)
  Coords atom_r, atom_d;         // per atom: closest_point's and pull_back's residual and update
  std::vector<ClusterSolve> solves;  // per cluster: closest_point's or pull_back's outcome
  Eigen::VectorXd g, delta, lambda;
  // Per cluster: outcome of the last solve.
  std::vector<int> iterations, worst;
  std::vector<double> deviation;
  std::vector<char> failed, singular;
};

namespace {

// The SETTLE geometry of a small cluster: three constraints joining three atoms, two of them of
// equal length (the apex's sides); invalid otherwise.
template <class Layout>
typename Layout::Triangle rigid_triangle(const Layout& L, const typename Layout::Cluster& cl) {
  typename Layout::Triangle t;
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

}  // namespace

Constraints::Constraints(std::vector<Constraint> list, int n_atoms, Box box)
    : list_(std::move(list)), n_atoms_(n_atoms), box_(box) {
  const int n = size();
  std::vector<std::pair<int, int>> pairs;
  pairs.reserve(n);
  for (int a = 0; a < n; ++a) {
    const Constraint& c = list_[a];
    const std::string name = "constraint " + std::to_string(a + 1) + " (atoms " + std::to_string(c.i + 1) + "-" +
                             std::to_string(c.j + 1) + ")";
    if (c.i < 0 || c.j < 0 || c.i >= n_atoms || c.j >= n_atoms)
      throw InputError("topology", 0, name + ": atom index outside 1.." + std::to_string(n_atoms));
    if (c.i == c.j) throw InputError("topology", 0, name + " joins an atom to itself");
    if (!(c.length > 0) || !std::isfinite(c.length))
      throw InputError("topology", 0, name + ": length must be positive, got " + format_number(c.length));
    pairs.emplace_back(std::min(c.i, c.j), std::max(c.i, c.j));
  }
  std::sort(pairs.begin(), pairs.end());
  if (auto dup = std::adjacent_find(pairs.begin(), pairs.end()); dup != pairs.end())
    throw InputError("topology", 0,
                     "atoms " + std::to_string(dup->first + 1) + " and " + std::to_string(dup->second + 1) +
                         " are constrained twice (the constraint matrix would be singular)");

  // Connected components over shared atoms (union–find).
  std::vector<int> parent(n_atoms);
  for (int k = 0; k < n_atoms; ++k) parent[k] = k;
  auto root = [&](int k) {
    while (parent[k] != k) k = parent[k] = parent[parent[k]];
    return k;
  };
  for (const Constraint& c : list_) parent[root(c.i)] = root(c.j);
  std::vector<int> cluster_of_root(n_atoms, -1);
  for (int a = 0; a < n; ++a) {
    int& id = cluster_of_root[root(list_[a].i)];
    if (id < 0) id = static_cast<int>(clusters_.size()), clusters_.emplace_back();
    clusters_[id].push_back(a);
  }

  auto layout = std::make_shared<Layout>();
  Layout& L = *layout;
  L.box = box_;
  L.n_atoms = n_atoms;
  L.ones = Eigen::VectorXd::Ones(n_atoms);
  std::vector<std::vector<int>> at_atom(n_atoms);  // local constraint indices per atom, per cluster
  // The couplings of the constraints at positions [begin, begin + m), in their current order.
  auto couple = [&](int begin, int m) {
    std::vector<Layout::Coupling> couplings;
    for (int a = 0; a < m; ++a) {
      at_atom[L.atom_i[begin + a]].push_back(a);
      at_atom[L.atom_j[begin + a]].push_back(a);
    }
    for (int a = 0; a < m; ++a)
      for (int atom : {L.atom_i[begin + a], L.atom_j[begin + a]})
        for (int b : at_atom[atom]) {
          if (b == a) continue;
          const double sa = L.atom_i[begin + a] == atom ? 1.0 : -1.0;
          const double sb = L.atom_i[begin + b] == atom ? 1.0 : -1.0;
          couplings.push_back({a, b, atom, sa * sb});
        }
    for (int a = 0; a < m; ++a) at_atom[L.atom_i[begin + a]].clear(), at_atom[L.atom_j[begin + a]].clear();
    return couplings;
  };
  auto pattern_of = [](int m, const std::vector<Layout::Coupling>& couplings) {
    std::vector<Eigen::Triplet<double>> entries;
    for (int a = 0; a < m; ++a) entries.emplace_back(a, a, 1.0);
    for (const auto& e : couplings) entries.emplace_back(e.a, e.b, 1.0);
    Eigen::SparseMatrix<double> pattern(m, m);
    pattern.setFromTriplets(entries.begin(), entries.end());
    pattern.makeCompressed();
    return pattern;
  };
  for (const auto& members : clusters_) {
    Layout::Cluster cl;
    cl.begin = static_cast<int>(L.atom_i.size());
    cl.end = cl.begin + static_cast<int>(members.size());
    for (int a : members) {
      L.atom_i.push_back(list_[a].i);
      L.atom_j.push_back(list_[a].j);
      L.original.push_back(a);
      L.length.push_back(list_[a].length);
    }
    const int m = cl.size();
    cl.kind = m <= kSmallMax ? Kind::Small : m <= kDenseMax ? Kind::Dense : Kind::Sparse;
    if (cl.kind == Kind::Small) {
      cl.slot = L.n_small++;
      L.triangles.push_back(rigid_triangle(L, cl));
      if (L.triangles.back().valid) L.triangle_clusters.push_back(static_cast<int>(L.clusters.size()));
      L.clusters.push_back(cl);
      continue;
    }
    if (cl.kind == Kind::Sparse) {
      // Order the cluster's constraints once for little fill in LDLᵀ (a linear chain becomes
      // tridiagonal whatever order the topology lists it in); the factorisations then need no
      // permutation per call. perm.indices()[new] = old.
      Eigen::PermutationMatrix<Eigen::Dynamic, Eigen::Dynamic, int> perm;
      Eigen::AMDOrdering<int>()(pattern_of(m, couple(cl.begin, m)), perm);
      auto reorder = [&](auto& v) {
        const std::vector<typename std::decay_t<decltype(v)>::value_type> old(v.begin() + cl.begin, v.begin() + cl.end);
        for (int a = 0; a < m; ++a) v[cl.begin + a] = old[perm.indices()[a]];
      };
      reorder(L.atom_i);
      reorder(L.atom_j);
      reorder(L.original);
      reorder(L.length);
    }
    cl.slot = static_cast<int>(L.dynamic.size());
    Layout::Dynamic d;
    d.couplings = couple(cl.begin, m);
    if (cl.kind == Kind::Sparse) {
      d.pattern = pattern_of(m, d.couplings);
      auto position = [&](int row, int col) {
        const int* inner = d.pattern.innerIndexPtr();
        const int* begin = inner + d.pattern.outerIndexPtr()[col];
        const int* end = inner + d.pattern.outerIndexPtr()[col + 1];
        return static_cast<int>(std::lower_bound(begin, end, row) - inner);
      };
      for (int a = 0; a < m; ++a) d.diagonal_position.push_back(position(a, a));
      for (const auto& e : d.couplings) d.coupling_position.push_back(position(e.a, e.b));
    }
    L.dynamic.push_back(std::move(d));
    L.clusters.push_back(cl);
  }
  L.atom_begin.push_back(0);
  for (const auto& cl : L.clusters) {
    for (int p = cl.begin; p < cl.end; ++p)
      for (int atom : {L.atom_i[p], L.atom_j[p]})
        if (std::find(L.atoms.begin() + L.atom_begin.back(), L.atoms.end(), atom) == L.atoms.end())
          L.atoms.push_back(atom);
    L.atom_begin.push_back(static_cast<int>(L.atoms.size()));
  }
  layout_ = std::move(layout);

  work_ = std::make_unique<Workspace>();
  Workspace& ws = *work_;
  ws.factorization.impl_->bind(layout_);
  ws.r_ref.resize(3, n);
  ws.r_cur.resize(3, n);
  ws.image.resize(3, n);
  ws.atom_r.setZero(3, n_atoms);
  ws.atom_d.setZero(3, n_atoms);
  ws.g.resize(n);
  ws.delta.resize(n);
  ws.lambda.resize(n);
  const std::size_t nc = clusters_.size();
  ws.iterations.assign(nc, 0);
  ws.worst.assign(nc, 0);
  ws.deviation.assign(nc, 0.0);
  ws.failed.assign(nc, 0);
  ws.singular.assign(nc, 0);
  ws.solves.resize(nc);
}

Constraints::Constraints() = default;
Constraints::~Constraints() = default;
Constraints::Constraints(Constraints&&) noexcept = default;
Constraints& Constraints::operator=(Constraints&&) noexcept = default;

Constraints::Factorization::Factorization() : impl_(std::make_unique<Impl>()) {}
Constraints::Factorization::~Factorization() = default;
Constraints::Factorization::Factorization(Factorization&&) noexcept = default;
Constraints::Factorization& Constraints::Factorization::operator=(Factorization&&) noexcept = default;

void Constraints::vectors(const Coords& q, Coords& r) const {
  r.resize(3, size());
  const int n = size();
#pragma omp parallel for schedule(static) if (n > kParallelMin)
  for (int a = 0; a < n; ++a) r.col(a) = box_.minimum_image(q.col(list_[a].i) - q.col(list_[a].j));
}

void Constraints::residuals(const Coords& q, Eigen::VectorXd& g) const {
  g.resize(size());
  const int n = size();
#pragma omp parallel for schedule(static) if (n > kParallelMin)
  for (int a = 0; a < n; ++a) {
    const Constraint& c = list_[a];
    g[a] = 0.5 * (box_.minimum_image(q.col(c.i) - q.col(c.j)).squaredNorm() - c.length * c.length);
  }
}

double Constraints::max_relative_deviation(const Coords& q) const {
  return parallel_max(size(), [&](int a) {
    const Constraint& c = list_[a];
    return relative_deviation(box_.minimum_image(q.col(c.i) - q.col(c.j)).squaredNorm(), c.length);
  });
}

double Constraints::max_velocity_residual(const Coords& q, const Coords& v) const {
  return parallel_max(size(), [&](int a) {
    const Constraint& c = list_[a];
    const Vec3 dv = v.col(c.i) - v.col(c.j);
    const double rate = box_.minimum_image(q.col(c.i) - q.col(c.j)).dot(dv);
    return std::abs(rate) / (c.length * std::max(1.0, dv.norm()));
  });
}

void Constraints::apply_G(const Coords& q, const Coords& u, Eigen::VectorXd& out) const {
  out.resize(size());
  const int n = size();
#pragma omp parallel for schedule(static) if (n > kParallelMin)
  for (int a = 0; a < n; ++a) {
    const Constraint& c = list_[a];
    out[a] = box_.minimum_image(q.col(c.i) - q.col(c.j)).dot(u.col(c.i) - u.col(c.j));
  }
}

// Atoms belong to one cluster only, so scattering per cluster is race-free.
void Constraints::add_GT(const Coords& q, const Eigen::VectorXd& lambda, Coords& out, const Eigen::VectorXd& w) const {
  if (empty()) return;
  const Layout& L = *layout_;
  const double* wp = L.weights(w);
  const int nc = static_cast<int>(L.clusters.size());
#pragma omp parallel for schedule(guided) if (size() > kParallelMin)
  for (int c = 0; c < nc; ++c)
    for (int p = L.clusters[c].begin; p < L.clusters[c].end; ++p) {
      const Vec3 r = L.bond(q, p) * lambda[L.original[p]];
      out.col(L.atom_i[p]) += wp[L.atom_i[p]] * r;
      out.col(L.atom_j[p]) -= wp[L.atom_j[p]] * r;
    }
}

void Constraints::add_H(const Eigen::VectorXd& c, const Coords& y, Coords& out, const Eigen::VectorXd& w) const {
  if (empty()) return;
  const Layout& L = *layout_;
  const double* wp = L.weights(w);
  const int nc = static_cast<int>(L.clusters.size());
#pragma omp parallel for schedule(guided) if (size() > kParallelMin)
  for (int k = 0; k < nc; ++k)
    for (int p = L.clusters[k].begin; p < L.clusters[k].end; ++p) {
      const Vec3 dy = c[L.original[p]] * (y.col(L.atom_i[p]) - y.col(L.atom_j[p]));
      out.col(L.atom_i[p]) += wp[L.atom_i[p]] * dy;
      out.col(L.atom_j[p]) -= wp[L.atom_j[p]] * dy;
    }
}

void Constraints::factorize(const Coords& q_left, const Coords& q_right, const Eigen::VectorXd& w,
                            Factorization& out) const {
  Factorization::Impl& f = *out.impl_;
  f.factorized = false;
  if (empty()) return;
  const Layout& L = *layout_;
  L.check_coords(q_left, "q_left");
  L.check_coords(q_right, "q_right");
  const double* wp = L.weights(w);
  f.bind(layout_);
  const int n = size();
  const bool symmetric = &q_left == &q_right;
#pragma omp parallel for schedule(static) if (n > kParallelMin)
  for (int p = 0; p < n; ++p) {
    f.r_left.col(p) = L.bond(q_left, p);
    if (!symmetric) f.r_right.col(p) = L.bond(q_right, p);
  }
  const Coords& rr = symmetric ? f.r_left : f.r_right;
  const int nc = static_cast<int>(L.clusters.size());
  int singular = -1;
#pragma omp parallel for schedule(guided) if (n > kParallelMin)
  for (int c = 0; c < nc; ++c)
    if (!f.factor(L.clusters[c], f.r_left, rr, wp, symmetric)) {
#pragma omp critical(vimd_constraints_singular)
      singular = std::max(singular, c);
    }
  if (singular >= 0)
    L.throw_singular(singular);
  f.symmetric = symmetric;
  f.factorized = true;
}

void Constraints::constrain_acceleration(const Coords& q, const Coords& v, const Eigen::VectorXd& w, Coords& a,
                                         Eigen::VectorXd& lambda, Factorization& s) const {
  Factorization::Impl& f = *s.impl_;
  f.factorized = false;
  lambda.resize(size());
  if (empty()) return;
  const Layout& L = *layout_;
  L.check_coords(q, "q");
  L.check_coords(v, "v");
  L.check_coords(a, "a");
  const double* wp = L.weights(w);
  f.bind(layout_);
  const int nc = static_cast<int>(L.clusters.size());
  int singular = -1;
#pragma omp parallel for schedule(guided) if (size() > kParallelMin)
  for (int c = 0; c < nc; ++c) {
    const auto& cl = L.clusters[c];
    for (int p = cl.begin; p < cl.end; ++p) f.r_left.col(p) = L.bond(q, p);
    if (!f.factor(cl, f.r_left, f.r_left, wp, true)) {
#pragma omp critical(vimd_constraints_singular)
      singular = std::max(singular, c);
      continue;
    }
    double* x = work_->delta.data() + cl.begin;
    for (int k = 0; k < cl.size(); ++k) {
      const int p = cl.begin + k, i = L.atom_i[p], j = L.atom_j[p];
      x[k] = -f.r_left.col(p).dot(a.col(i) - a.col(j)) - (v.col(i) - v.col(j)).squaredNorm();
    }
    f.solve(cl, x);
    for (int k = 0; k < cl.size(); ++k) {
      const int p = cl.begin + k;
      lambda[L.original[p]] = x[k];
      L.move_along_bond(p, f.r_left.col(p), -x[k], wp, a);
    }
  }
  if (singular >= 0)
    L.throw_singular(singular);
  f.symmetric = true;
  f.factorized = true;
}

void Constraints::project_onto_kernel(const Factorization& s, const Eigen::VectorXd& w, Coords& u,
                                      Eigen::VectorXd& mu) const {
  mu.resize(size());
  if (empty()) return;
  Factorization::Impl& f = *s.impl_;
  if (!f.factorized || !f.symmetric || f.layout != layout_)
    throw std::logic_error("Constraints::project_onto_kernel needs a symmetric factorisation of these constraints");
  const Layout& L = *layout_;
  L.check_coords(u, "u");
  const double* wp = L.weights(w);
  const int nc = static_cast<int>(L.clusters.size());
#pragma omp parallel for schedule(guided) if (size() > kParallelMin)
  for (int c = 0; c < nc; ++c) {
    const auto& cl = L.clusters[c];
    double* x = work_->delta.data() + cl.begin;
    for (int k = 0; k < cl.size(); ++k) {
      const int p = cl.begin + k;
      x[k] = f.r_left.col(p).dot(u.col(L.atom_i[p]) - u.col(L.atom_j[p]));
    }
    f.solve(cl, x);
    for (int k = 0; k < cl.size(); ++k) {
      const int p = cl.begin + k;
      mu[L.original[p]] = x[k];
      L.move_along_bond(p, f.r_left.col(p), x[k], wp, u);
    }
  }
}

template <class Solve>
Constraints::ClusterSolve Constraints::copy_then_solve_clusters(const Coords& in, Coords& out, Solve&& solve) const {
  const Layout& L = *layout_;
  out.resize(3, n_atoms_);
  std::vector<ClusterSolve>& outcome = work_->solves;
  std::fill(outcome.begin(), outcome.end(), ClusterSolve{});
  const int nc = static_cast<int>(L.clusters.size());
#pragma omp parallel if (n_atoms_ > kParallelMin)
  {
#pragma omp for schedule(static)
    for (int i = 0; i < n_atoms_; ++i) out.col(i) = in.col(i);
#pragma omp for schedule(guided)
    for (int c = 0; c < nc; ++c)
      solve(c, L.atoms.data() + L.atom_begin[c], L.atom_begin[c + 1] - L.atom_begin[c], outcome[c]);
  }
  ClusterSolve all;
  for (const auto& c : outcome) {
    all.iterations = std::max(all.iterations, c.iterations);
    all.residual = std::max(all.residual, c.residual);
    all.converged = all.converged && c.converged;
  }
  return all;
}

Constraints::ClusterSolve Constraints::closest_point(const Coords& y, const Eigen::VectorXd& w, double tolerance,
                                                     int max_iterations, Coords& x, Eigen::VectorXd& theta,
                                                     Factorization& s) const {
  if (empty()) {
    x = y;
    theta.resize(0);
    return {};
  }
  const Layout& L = *layout_;
  L.check_coords(y, "y");
  theta.setZero(size());
  Factorization::Impl& f = *s.impl_;
  f.factorized = false;
  f.bind(layout_);
  const double* wp = L.weights(w);
  Workspace& ws = *work_;
  Coords &r1 = ws.atom_r, &dx = ws.atom_d;
  int singular = -1;
  const ClusterSolve all = copy_then_solve_clusters(y, x, [&](int c, const int* atom, int n_cluster_atoms,
                                                               ClusterSolve& out) {
    const auto& cl = L.clusters[c];
    double* rhs = ws.delta.data() + cl.begin;
    double change = std::numeric_limits<double>::infinity();
    while (change > tolerance) {
      if (out.iterations == max_iterations || (out.iterations > 0 && !std::isfinite(change))) {
        out.converged = false;
        break;
      }
      ++out.iterations;
      // R1 = x + WGᵀθ − y,  R2 = g(x);  dθ = S⁻¹(R2 − G R1),  dx = −R1 − WGᵀdθ.
      for (int k = 0; k < n_cluster_atoms; ++k) r1.col(atom[k]) = x.col(atom[k]) - y.col(atom[k]);
      for (int p = cl.begin; p < cl.end; ++p) {
        f.r_left.col(p) = L.bond(x, p);
        L.move_along_bond(p, f.r_left.col(p), -theta[L.original[p]], wp, r1);
      }
      if (!f.factor(cl, f.r_left, f.r_left, wp, true)) {
#pragma omp critical(vimd_constraints_singular)
        singular = std::max(singular, c);
        break;
      }
      for (int p = cl.begin; p < cl.end; ++p) {
        const Vec3& r = f.r_left.col(p);
        rhs[p - cl.begin] = 0.5 * (r.squaredNorm() - L.length[p] * L.length[p]) -
                            r.dot(r1.col(L.atom_i[p]) - r1.col(L.atom_j[p]));
      }
      f.solve(cl, rhs);
      for (int k = 0; k < n_cluster_atoms; ++k) dx.col(atom[k]) = -r1.col(atom[k]);
      for (int p = cl.begin; p < cl.end; ++p) {
        L.move_along_bond(p, f.r_left.col(p), rhs[p - cl.begin], wp, dx);
        theta[L.original[p]] += rhs[p - cl.begin];
      }
      change = 0;
      for (int k = 0; k < n_cluster_atoms; ++k) {
        x.col(atom[k]) += dx.col(atom[k]);
        change = std::max(change, dx.col(atom[k]).cwiseAbs().maxCoeff());
      }
      if (std::isnan(change)) change = std::numeric_limits<double>::infinity();
    }
    out.residual = change;
  });
  if (singular >= 0) L.throw_singular(singular);
  f.symmetric = true;
  f.factorized = true;
  return all;
}

Constraints::ClusterSolve Constraints::pull_back(const Coords& x, const Eigen::VectorXd& theta, const Factorization& s,
                                                 const Eigen::VectorXd& w, const Coords& p, double tolerance,
                                                 int max_sweeps, Coords& p_hat) const {
  if (empty()) {
    p_hat = p;
    return {};
  }
  const Layout& L = *layout_;
  L.check_coords(x, "x");
  L.check_coords(p, "p");
  Factorization::Impl& f = *s.impl_;
  if (!f.factorized || f.layout != layout_)
    throw std::logic_error("Constraints::pull_back needs closest_point's factorisation of these constraints");
  const double* wp = L.weights(w);
  Workspace& ws = *work_;
  Coords &r1 = ws.atom_r, &scaled = ws.atom_d;
  return copy_then_solve_clusters(p, p_hat, [&](int c, const int* atom, int n_cluster_atoms, ClusterSolve& out) {
    const auto& cl = L.clusters[c];
    double* b = ws.lambda.data() + cl.begin;
    double* db = ws.delta.data() + cl.begin;
    for (int q = cl.begin; q < cl.end; ++q) {
      ws.r_cur.col(q) = L.bond(x, q);
      b[q - cl.begin] = 0;
    }
    out.converged = false;
    while (out.iterations < max_sweeps) {
      ++out.iterations;
      // r1 = p − (I + Σθ_a H_a W) p̂ − Gᵀb,  r2 = −G W p̂;
      // correction from [[I, Gᵀ], [G W, 0]]: db = S⁻¹(G W r1 − r2), dp = r1 − Gᵀ db.
      for (int k = 0; k < n_cluster_atoms; ++k) {
        scaled.col(atom[k]) = wp[atom[k]] * p_hat.col(atom[k]);
        r1.col(atom[k]) = p.col(atom[k]) - p_hat.col(atom[k]);
      }
      for (int q = cl.begin; q < cl.end; ++q) {
        const int i = L.atom_i[q], j = L.atom_j[q];
        const Vec3& r = ws.r_cur.col(q);
        const Vec3 bent = theta[L.original[q]] * (scaled.col(i) - scaled.col(j)) + b[q - cl.begin] * r;
        r1.col(i) -= bent;
        r1.col(j) += bent;
      }
      for (int q = cl.begin; q < cl.end; ++q) {
        const int i = L.atom_i[q], j = L.atom_j[q];
        const Vec3& r = ws.r_cur.col(q);
        db[q - cl.begin] = r.dot(scaled.col(i) - scaled.col(j)) + r.dot(wp[i] * r1.col(i) - wp[j] * r1.col(j));
      }
      f.solve(cl, db);
      for (int q = cl.begin; q < cl.end; ++q) {
        b[q - cl.begin] += db[q - cl.begin];
        const Vec3 moved = db[q - cl.begin] * ws.r_cur.col(q);
        r1.col(L.atom_i[q]) -= moved;
        r1.col(L.atom_j[q]) += moved;
      }
      double size = 0;
      for (int k = 0; k < n_cluster_atoms; ++k) {
        p_hat.col(atom[k]) += r1.col(atom[k]);
        size = std::max(size, r1.col(atom[k]).cwiseAbs().maxCoeff());
      }
      out.residual = std::isnan(size) ? std::numeric_limits<double>::infinity() : size;
      if (out.residual <= tolerance) {
        out.converged = true;
        break;
      }
    }
  });
}


void Constraints::Factorization::solve(Eigen::VectorXd& rhs) const {
  if (!impl_->layout) {
    if (rhs.size() == 0) return;
    throw std::logic_error("Constraints::Factorization::solve called before factorize");
  }
  Impl& f = *impl_;
  const Layout& L = *f.layout;
  if (!f.factorized) throw std::logic_error("Constraints::Factorization::solve called before factorize");
  if (rhs.size() != static_cast<Eigen::Index>(L.original.size()))
    throw std::invalid_argument("Constraints::Factorization::solve: right-hand side has wrong size");
  const int nc = static_cast<int>(L.clusters.size());
#pragma omp parallel for schedule(guided) if (rhs.size() > kParallelMin)
  for (int c = 0; c < nc; ++c) {
    const auto& cl = L.clusters[c];
    double local[kSmallMax];
    double* x = cl.kind == Kind::Small ? local : f.dynamic[cl.slot].x.data();
    // Gather into cluster order; solve() copies dynamic clusters into their rhs buffer first,
    // so using x as the carrier does not alias.
    for (int a = 0; a < cl.size(); ++a) x[a] = rhs[L.original[cl.begin + a]];
    f.solve(cl, x);
    for (int a = 0; a < cl.size(); ++a) rhs[L.original[cl.begin + a]] = x[a];
  }
}

namespace {

// Bond vectors r = q_i − q_j + image and g_a of one cluster at q (cluster order). Returns whether
// every bond is within the tolerance window; sets finite and size = max |g_a| / d_a² (≈ the
// worst relative deviation, to judge the convergence rate).
template <class Layout>
bool measure(const Layout& L, const typename Layout::Cluster& cl, const Coords& q, const Coords& image,
             double tolerance, Coords& r, Eigen::VectorXd& g, bool& finite, double& size) {
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

// The worst relative deviation of a cluster from the bond vectors measure() stored.
template <class Layout>
void exact_deviation(const Layout& L, const typename Layout::Cluster& cl, const Coords& r, ClusterOutcome& out) {
  out.deviation = 0;
  out.worst = cl.begin;
  for (int p = cl.begin; p < cl.end; ++p) {
    const double dev = relative_deviation(r.col(p).squaredNorm(), L.length[p]);
    if (dev > out.deviation) out.deviation = dev, out.worst = p;
  }
}

}  // namespace

int Constraints::solve_positions(const Coords& q_ref, Coords& q, const Eigen::VectorXd& w, double tolerance, long step,
                                 int max_iterations, Eigen::VectorXd* lambda_out, double* max_deviation_out) const {
  if (lambda_out) lambda_out->setZero(size());
  if (max_deviation_out) *max_deviation_out = 0;
  if (empty()) return 0;
  if (!(tolerance > 0)) throw std::invalid_argument("constraint tolerance must be positive");
  const Layout& L = *layout_;
  L.check_coords(q_ref, "q_ref");
  L.check_coords(q, "q");
  const double* wp = L.weights(w);
  Workspace& ws = *work_;
  Factorization::Impl& f = *ws.factorization.impl_;
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
    double previous = std::numeric_limits<double>::infinity();
    for (;;) {
      bool finite;
      double size;
      if (measure(L, cl, q, ws.image, tolerance, ws.r_cur, ws.g, finite, size)) {
        exact_deviation(L, cl, ws.r_cur, out);
        if (out.deviation <= tolerance) return out;
      }
      if (!finite) {
        out.deviation = std::numeric_limits<double>::quiet_NaN();
        out.failed = true;
        return out;
      }
      if (out.iterations >= max_iterations) {
        exact_deviation(L, cl, ws.r_cur, out);
        out.failed = true;
        return out;
      }
      // The Jacobian of g(q + W G(q_ref)ᵀ λ) is G(q) W G(q_ref)ᵀ. Dense clusters use it every
      // iteration; sparse ones start from the symmetric S(q_ref) (one cheap LDLᵀ) and switch to
      // the exact matrix only when that converges slowly.
      const bool chord_start = cl.kind == Kind::Sparse && out.iterations == 0;
      const bool refresh = cl.kind == Kind::Dense || chord_start || size > kChordRate * previous;
      if (refresh && !f.factor(cl, chord_start ? ws.r_ref : ws.r_cur, ws.r_ref, wp, chord_start)) {
        exact_deviation(L, cl, ws.r_cur, out);
        out.failed = out.singular = true;
        return out;
      }
      for (int a = 0; a < m; ++a) delta[a] = -ws.g[b + a];
      f.solve(cl, delta);
      for (int a = 0; a < m; ++a) {
        L.move_along_bond(b + a, ws.r_ref.col(b + a), -delta[a], wp, q);
        ws.lambda[b + a] += delta[a];
      }
      previous = size;
      ++out.iterations;
    }
  };

  auto record = [&](int c, const ClusterOutcome& out) {
    ws.iterations[c] = out.iterations;
    ws.worst[c] = out.worst;
    ws.deviation[c] = out.deviation;
    ws.failed[c] = out.failed;
    ws.singular[c] = out.singular;
  };
  auto newton = [&](const Layout::Cluster& cl) {
    return cl.kind == Kind::Small
               ? L.solve_small_positions(cl, q_ref, q, wp, tolerance, max_iterations, ws.lambda.data() + cl.begin)
               : solve_dynamic(cl);
  };
  // SETTLE gives positions, not multipliers: only where nobody asks for them. Rigid triangles go
  // in batches of kSettleBatch through the SIMD kernel; every other cluster, and a triangle SETTLE
  // cannot take, through Newton.
  const bool settle = !lambda_out && !L.triangle_clusters.empty();
  if (settle) {
    const SettleKernel kernel = simd::settle_kernel();
    const int n_triangles = static_cast<int>(L.triangle_clusters.size());
    const int n_batches = (n_triangles + kSettleBatch - 1) / kSettleBatch;
#pragma omp parallel for schedule(guided) if (size() > kParallelMin)
    for (int batch = 0; batch < n_batches; ++batch) {
      double in[kSettleInFields * kSettleBatch], result[kSettleOutFields * kSettleBatch];
      Layout::SettlePending pending[kSettleBatch];
      int count = 0;
      for (int k = batch * kSettleBatch; k < std::min(n_triangles, (batch + 1) * kSettleBatch); ++k) {
        const int c = L.triangle_clusters[k];
        ClusterOutcome out;
        switch (L.settle_prepare(L.clusters[c], q_ref, q, wp, tolerance, in, count, pending[count], out)) {
          case Layout::Settle::prepared: pending[count++].cluster = c; break;
          case Layout::Settle::already_satisfied: record(c, out); break;
          case Layout::Settle::not_applicable: record(c, newton(L.clusters[c])); break;
        }
      }
      if (count == 0) continue;
      pad_batch(in, kSettleInFields, count);
      kernel(count, in, result);
      for (int k = 0; k < count; ++k) {
        const auto& cl = L.clusters[pending[k].cluster];
        ClusterOutcome out;
        if (!L.settle_finish(cl, pending[k], result, k, q, tolerance, out)) out = newton(cl);
        record(pending[k].cluster, out);
      }
    }
  }
#pragma omp parallel for schedule(guided) if (size() > kParallelMin)
  for (int c = 0; c < nc; ++c) {
    const auto& cl = L.clusters[c];
    if (settle && cl.kind == Kind::Small && L.triangles[cl.slot].valid) continue;  // done above
    record(c, newton(cl));
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

void Constraints::project_velocities(const Coords& q, Coords& v, const Eigen::VectorXd& w,
                                     Eigen::VectorXd* mu_out) const {
  if (mu_out) mu_out->setZero(size());
  if (empty()) return;
  const Layout& L = *layout_;
  L.check_coords(q, "q");
  L.check_coords(v, "v");
  const double* wp = L.weights(w);
  Workspace& ws = *work_;
  Factorization::Impl& f = *ws.factorization.impl_;
  const int nc = static_cast<int>(L.clusters.size());
  // Rigid triangles in batches through the SIMD kernel; every other cluster one by one.
  const ProjectionKernel kernel = simd::triangle_projection_kernel();
  const int n_triangles = static_cast<int>(L.triangle_clusters.size());
  const int n_batches = (n_triangles + kSettleBatch - 1) / kSettleBatch;
#pragma omp parallel if (size() > kParallelMin)
  {
#pragma omp for schedule(static) nowait
    for (int batch = 0; batch < n_batches; ++batch) {
      double in[kProjectionInFields * kSettleBatch], x[3 * kSettleBatch];
      const int first = batch * kSettleBatch, count = std::min(n_triangles - first, kSettleBatch);
      for (int k = 0; k < count; ++k) L.projection_prepare(L.clusters[L.triangle_clusters[first + k]], q, v, wp, in, k);
      pad_batch(in, kProjectionInFields, count);
      kernel(count, in, x);
      for (int k = 0; k < count; ++k) {
        const int c = L.triangle_clusters[first + k];
        L.projection_finish(L.clusters[c], in, x, k, v, wp, ws.delta.data() + L.clusters[c].begin);
        ws.singular[c] = false;
      }
    }
#pragma omp for schedule(guided)
    for (int c = 0; c < nc; ++c) {
      const auto& cl = L.clusters[c];
      if (cl.kind == Kind::Small && L.triangles[cl.slot].valid) continue;  // done above
      const int b = cl.begin, m = cl.size();
      double* mu = ws.delta.data() + b;
      if (cl.kind == Kind::Small) {
        L.project_small_velocities(cl, q, v, wp, mu);
        ws.singular[c] = false;
        continue;
      }
      for (int a = 0; a < m; ++a) {
        const int i = L.atom_i[b + a], j = L.atom_j[b + a];
        ws.r_cur.col(b + a) = L.bond(q, b + a);
        mu[a] = ws.r_cur.col(b + a).dot(v.col(i) - v.col(j));
      }
      ws.singular[c] = !f.factor(cl, ws.r_cur, ws.r_cur, wp, true);
      if (ws.singular[c]) continue;
      f.solve(cl, mu);
      for (int a = 0; a < m; ++a) L.move_along_bond(b + a, ws.r_cur.col(b + a), mu[a], wp, v);
    }
  }
  for (int c = 0; c < nc; ++c)
    if (ws.singular[c])
      L.throw_singular(c);
  if (mu_out)
    for (int p = 0; p < size(); ++p) (*mu_out)[L.original[p]] = ws.delta[p];
}

}  // namespace vimd
