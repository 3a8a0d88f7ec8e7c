#pragma once
// The inside of the constraint solvers, shared by the files that implement them and by solvers
// elsewhere that work cluster by cluster (integrators/closest_point.cpp); everyone else uses
// engine/constraints.hpp. Layout: the constraint list reordered so that every cluster of coupled
// constraints is contiguous, with what each cluster's solve needs. ClusterFactors: S = G W Gᵀ
// factorised per cluster. Workspace: a Constraints object's scratch.
#include <Eigen/LU>
#include <Eigen/SparseCore>
#include <cmath>
#include <cstdio>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "engine/box.hpp"
#include "engine/constraints.hpp"
#include "engine/types.hpp"

namespace vimd::constraint_internals {

// Clusters of up to three constraints (rigid water, single bonds) use padded 3×3 kernels with
// everything on the stack; up to kDenseMax a dense LU; beyond that (whole chains) a sparse one.
inline constexpr int kSmallMax = 3;
inline constexpr int kDenseMax = 16;
// OpenMP only pays off above this many constraints (atoms, for loops over atoms).
inline constexpr int kParallelMin = 1000;

enum class Kind { Small, Dense, Sparse };

// | |r| − d | / d from r². The cancellation in |r| − d costs nothing that matters: its absolute
// error is a few ulp of d, i.e. 1e-16, far below any usable tolerance.
inline double relative_deviation(double r2, double d) { return std::abs(std::sqrt(r2) - d) / d; }

// r² inside [(d(1 − tol))², (d(1 + tol))²] ⇔ relative deviation ≤ tol (up to rounding): the
// iterations test this, without a square root or division, and compute the exact deviation only
// once every bond of a cluster passes it.
inline bool within(double r2, double d, double tolerance) {
  const double lo = d * (1 - tolerance), hi = d * (1 + tolerance);
  return r2 >= lo * lo && r2 <= hi * hi;
}

inline std::string format_number(double x) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3e", x);
  return buf;
}

// How one cluster's position solve ended.
struct ClusterOutcome {
  int iterations = 0;
  int worst = 0;  // position of the worst constraint
  double deviation = 0;
  bool failed = false, singular = false;
};

struct Layout {
  struct Cluster {
    int begin, end;  // range in the cluster-ordered arrays below
    Kind kind;
    int slot;  // index into the small or dynamic storage of a ClusterFactors
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
  std::vector<int> other_clusters;     // and all the others, in order
  // Per SETTLE batch of triangle_clusters: the apex of its first molecule where its molecules are
  // consecutive atoms, apex, h1, h2 in turn (a water box as written), whose positions then move in
  // whole vectors; −1 elsewhere.
  std::vector<int> consecutive_settle_batches;
  // The atoms of each cluster, once each: those of cluster c at [atom_begin[c], atom_begin[c + 1]).
  std::vector<int> atoms, atom_begin;

  int n_constraints() const { return static_cast<int>(original.size()); }
  bool is_triangle(const Cluster& cl) const { return cl.kind == Kind::Small && triangles[cl.slot].valid; }
  Vec3 bond(const Coords& q, int p) const { return box.minimum_image(q.col(atom_i[p]) - q.col(atom_j[p])); }
  // x ← x − s W Gᵀ_p for constraint p with bond vector r: its atoms move by ∓ s w along r.
  void move_along_bond(int p, const Vec3& r, double s, const double* w, Coords& x) const {
    x.col(atom_i[p]) -= (w[atom_i[p]] * s) * r;
    x.col(atom_j[p]) += (w[atom_j[p]] * s) * r;
  }
  // StepVelocity for the atoms of cluster c.
  void set_step_velocity(int c, const Coords& q_ref, const Coords& q, const StepVelocity& velocity) const {
    for (int k = atom_begin[c]; k < atom_begin[c + 1]; ++k)
      velocity.v.col(atoms[k]) = (q.col(atoms[k]) - q_ref.col(atoms[k])) * (1 / velocity.h);
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
  // The per-atom weights a caller passed (an empty vector means all ones), checked.
  const double* weights(const Eigen::VectorXd& weights) const {
    if (weights.size() == 0) return ones.data();
    if (weights.size() != n_atoms)
      throw std::invalid_argument("constraint weights: " + std::to_string(weights.size()) + " values for " +
                                  std::to_string(n_atoms) + " atoms");
    return weights.data();
  }
  void check_coords(const Coords& x, const char* what) const {
    if (x.cols() != n_atoms)
      throw std::invalid_argument(std::string("constraints: ") + what + " has " + std::to_string(x.cols()) +
                                  " atoms, the system " + std::to_string(n_atoms));
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

// S = G_left W G_rightᵀ factorised cluster by cluster: what a Constraints::Factorization holds.
// The dense and sparse clusters' factorisations live in engine/cluster_factors.cpp, so that Eigen's
// LU and sparse solvers, slow to compile, are instantiated in that one file and not in every
// includer; small clusters, the hot path, stay inline here.
struct ClusterFactors {
  struct Dynamic;  // a dense or sparse cluster's matrix, factors and solve buffers
  // Dynamic is complete only in cluster_factors.cpp, so deleting it must happen there.
  struct DeleteDynamic {
    void operator()(Dynamic* d) const;
  };

  std::shared_ptr<const Layout> layout;
  // S⁻¹ of each small cluster in closed form (Eigen's 3×3 cofactor inverse), a third of the cost
  // of a pivoted LU and its solves; a degenerate (collinear) triangle gives non-finite values as
  // the LU did.
  std::vector<Eigen::Matrix3d> small_inverse;
  std::unique_ptr<Dynamic[], DeleteDynamic> dynamic;  // SparseLU is not movable, so no std::vector
  Coords r_left, r_right;
  bool factorized = false;
  bool symmetric = false;  // factorised with q_left = q_right: r_left holds G's bond vectors

  // Sizes the storage for a layout once; later calls with the same layout are free.
  void bind(const std::shared_ptr<const Layout>& l);

  // Factorises S = G_left W G_rightᵀ of one cluster from its bond vectors (columns of the
  // cluster-ordered arrays). False if a sparse factorisation finds S singular.
  bool factor(const Layout::Cluster& cl, const Coords& rl, const Coords& rr, const double* w, bool symmetric) {
    if (cl.kind != Kind::Small) return factor_dynamic(cl, rl, rr, w, symmetric);
    const Layout& L = *layout;
    const int b = cl.begin, m = cl.size();
    Eigen::Matrix3d s = Eigen::Matrix3d::Identity();  // unused rows stay identity
    for (int a = 0; a < m; ++a)
      for (int c = 0; c < m; ++c) s(a, c) = L.coefficient(b + a, b + c, w) * rl.col(b + a).dot(rr.col(b + c));
    small_inverse[cl.slot] = s.inverse();
    return true;
  }

  // x ← S⁻¹ x for one cluster; x points at the cluster's m values.
  void solve(const Layout::Cluster& cl, double* x) {
    if (cl.kind != Kind::Small) return solve_dynamic(cl, x);
    const int m = cl.size();
    // Loops of fixed length: with m as their bound, g++ turns them into memcpy calls.
    Eigen::Vector3d rhs;
    for (int a = 0; a < kSmallMax; ++a) rhs[a] = a < m ? x[a] : 0.0;
    const Eigen::Vector3d sol = small_inverse[cl.slot] * rhs;
    for (int a = 0; a < kSmallMax; ++a)
      if (a < m) x[a] = sol[a];
  }

  // A buffer of a dense or sparse cluster's size, free between solves.
  double* scratch(const Layout::Cluster& cl);

 private:
  bool factor_dynamic(const Layout::Cluster& cl, const Coords& rl, const Coords& rr, const double* w, bool symmetric);
  void solve_dynamic(const Layout::Cluster& cl, double* x);
};

// A Constraints object's scratch, reused across calls so that a step does not allocate (its
// solves therefore must not run concurrently on the same object). Per constraint in cluster
// order unless said otherwise.
struct Workspace {
  Constraints::Factorization factorization;  // solvers of the dense and sparse clusters
  Coords r_ref, r_cur;                        // bond vectors
  Coords image;                               // minimum_image(q_i − q_j) − (q_i − q_j)
  Eigen::VectorXd g, delta, lambda;
  // Per cluster: outcome of the last position solve (or, in singular, velocity projection).
  std::vector<int> iterations, worst;
  std::vector<double> deviation;
  std::vector<char> failed, singular;

  void record(int cluster, const ClusterOutcome& out) {
    iterations[cluster] = out.iterations;
    worst[cluster] = out.worst;
    deviation[cluster] = out.deviation;
    failed[cluster] = out.failed;
    singular[cluster] = out.singular;
  }
};

// Newton for a cluster of at most three constraints (engine/shake_rattle_solve.cpp): the position
// stage of Constraints::solve_positions, accumulating the multipliers in lambda (cluster order).
ClusterOutcome solve_small_positions(const Layout& L, const Layout::Cluster& cl, const Coords& q_ref, Coords& q,
                                     const double* w, double tolerance, int max_iterations, double* lambda);

// Rigid water (engine/settle.cpp).
// The triangle a small cluster forms, if it is one SETTLE can take (invalid otherwise).
Layout::Triangle rigid_triangle(const Layout& L, const Layout::Cluster& cl);
// Layout::consecutive_settle_batches of a layout whose triangles are known.
std::vector<int> consecutive_settle_batches(const Layout& L);
// SETTLE's position stage for every rigid triangle, in SIMD batches, each cluster's outcome
// recorded in ws; a triangle SETTLE cannot take goes through solve_small_positions.
void settle_positions(const Layout& L, const Coords& q_ref, Coords& q, const double* w, double tolerance,
                      int max_iterations, Workspace& ws, const StepVelocity* velocity);
// The velocity projection of every rigid triangle, in SIMD batches: multipliers into ws.delta,
// ws.singular cleared. A worksharing loop (schedule static, nowait) for inside a parallel region.
void project_triangle_velocities(const Layout& L, const Coords& q, Coords& v, const double* w, Workspace& ws);

}  // namespace vimd::constraint_internals
