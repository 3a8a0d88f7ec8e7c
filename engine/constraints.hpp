#pragma once
// Holonomic distance constraints g_a(q) = ½(|q_i − q_j|² − d_a²) and the linear algebra every
// constrained integrator needs: G = Dg, Gᵀλ, the constant Hessians H_a, and solves with
// S = G(q_left) W G(q_right)ᵀ factorised per coupled cluster (3×3 for rigid water, sparse for chains).
// All differences go through the box's minimum image.
#include <memory>
#include <vector>

#include "engine/box.hpp"
#include "engine/system.hpp"
#include "engine/types.hpp"

namespace vimd {

class Constraints {
 public:
  Constraints();
  Constraints(std::vector<Constraint> list, int n_atoms, Box box);
  ~Constraints();
  Constraints(Constraints&&) noexcept;
  Constraints& operator=(Constraints&&) noexcept;

  int size() const { return static_cast<int>(list_.size()); }
  bool empty() const { return list_.empty(); }
  const std::vector<Constraint>& list() const { return list_; }
  const Box& box() const { return box_; }

  // r_a = q_i − q_j (minimum image), one column per constraint.
  void vectors(const Coords& q, Coords& r) const;
  // g_a = ½(|r_a|² − d_a²)
  void residuals(const Coords& q, Eigen::VectorXd& g) const;
  // max_a | |r_a| − d_a | / d_a
  double max_relative_deviation(const Coords& q) const;
  // max_a |r_a·(v_i − v_j)| / (d_a · max(1, |v_i − v_j|)): relative velocity-constraint residual.
  double max_velocity_residual(const Coords& q, const Coords& v) const;

  // G and Gᵀ alone: the solves below fuse them; tests check those against these.
  // out_a = r_a(q)·(u_i − u_j)
  void apply_G(const Coords& q, const Coords& u, Eigen::VectorXd& out) const;
  // out += G(q)ᵀ λ, scaled per atom by w when w is non-empty (out += W Gᵀλ)
  void add_GT(const Coords& q, const Eigen::VectorXd& lambda, Coords& out,
              const Eigen::VectorXd& w = Eigen::VectorXd()) const;
  // out += Σ_a c_a H_a y, i.e. c_a (y_i − y_j) at i and −c_a (y_i − y_j) at j (W-scaled if w given)
  void add_H(const Eigen::VectorXd& c, const Coords& y, Coords& out,
             const Eigen::VectorXd& w = Eigen::VectorXd()) const;

  // S = G(q_left) diag(w) G(q_right)ᵀ with w per atom (inverse masses, or ones), factorised
  // once per coupled cluster of constraints. Reusable storage: factorize into the same object.
  // Passing the same Coords object as q_left and q_right marks S symmetric: chain-sized clusters
  // then use a sparse LDLᵀ instead of a sparse LU.
  class Factorization {
   public:
    Factorization();
    ~Factorization();
    Factorization(Factorization&&) noexcept;
    Factorization& operator=(Factorization&&) noexcept;
    // rhs ← S⁻¹ rhs (uses internal buffers: one solve at a time per Factorization)
    void solve(Eigen::VectorXd& rhs) const;

   private:
    friend class Constraints;
    struct Impl;
    std::unique_ptr<Impl> impl_;
  };
  void factorize(const Coords& q_left, const Coords& q_right, const Eigen::VectorXd& w, Factorization& out) const;

  // The two solves of the constrained dynamics, each in one pass over the clusters (bond vectors,
  // S, solve and scatter per cluster) rather than the four of apply_G, factorize, solve and add_GT.
  // Same arithmetic as that sequence.
  //
  // a ← a + W Gᵀλ with S λ = −G a − D²g(v,v), S = G W Gᵀ at q (factorised into `s`, symmetric):
  // the index-1 acceleration when a enters as W f. D²g_a(v,v) = |v_i − v_j|² (no minimum image).
  void constrain_acceleration(const Coords& q, const Coords& v, const Eigen::VectorXd& w, Coords& a,
                              Eigen::VectorXd& lambda, Factorization& s) const;
  // u ← u − W Gᵀμ with μ = S⁻¹ G u, G and S = G W Gᵀ those `s` was factorised at (symmetric, with
  // these w): the W-orthogonal projection of u onto ker G. μ into mu.
  void project_onto_kernel(const Factorization& s, const Eigen::VectorXd& w, Coords& u, Eigen::VectorXd& mu) const;

  // The closest-point projection x = P(y) of the variational integrator and its pull-back, each
  // cluster iterated on its own (its atoms are no other cluster's) until its update is at most
  // `tolerance` (max abs over its atoms); atoms under no constraint are copied. W = diag(w).
  struct ClusterSolve {
    int iterations = 0;   // the most any cluster took
    double residual = 0;  // the largest last update
    bool converged = true;
  };
  // y = x + W G(x)ᵀθ, g(x) = 0, by Newton with the Jacobian [[I, WGᵀ], [G, 0]] at the iterate.
  // θ into theta; S = G W Gᵀ at each cluster's last iterate before x into s.
  ClusterSolve closest_point(const Coords& y, const Eigen::VectorXd& w, double tolerance, int max_iterations,
                             Coords& x, Eigen::VectorXd& theta, Factorization& s) const;
  // p̂ = p·DP(y) at x = P(y), with θ and s from closest_point:
  // [[I + Σθ_a H_a W, Gᵀ], [G W, 0]] [p̂; b] = [p; 0], by sweeps preconditioned with s.
  ClusterSolve pull_back(const Coords& x, const Eigen::VectorXd& theta, const Factorization& s,
                         const Eigen::VectorXd& w, const Coords& p, double tolerance, int max_sweeps,
                         Coords& p_hat) const;

  // SHAKE/RATTLE position stage: q ← q + diag(w) G(q_ref)ᵀ λ with λ chosen so that every
  // constraint holds to a relative deviation | |r_a| − d_a | / d_a ≤ tolerance (the measure of
  // max_relative_deviation). Newton on λ per cluster (exact Jacobian G(q) W G(q_ref)ᵀ for small
  // and dense clusters; chains start from a factorisation of the symmetric S(q_ref)). Returns the
  // iterations taken (maximum over clusters); throws ConvergenceError(step, iterations, worst
  // relative deviation, worst constraint with its 1-based atoms) when it cannot. lambda_out
  // (optional) receives the accumulated multipliers, max_deviation_out (optional) the final
  // maximum relative deviation (saves a max_relative_deviation pass). An empty w means all ones.
  int solve_positions(const Coords& q_ref, Coords& q, const Eigen::VectorXd& w, double tolerance, long step,
                      int max_iterations = 500, Eigen::VectorXd* lambda_out = nullptr,
                      double* max_deviation_out = nullptr) const;
  // v ← v − diag(w) Gᵀ S⁻¹ G v at q: the W-orthogonal projection onto the tangent space
  // (the RATTLE velocity stage when w = M⁻¹). mu_out (optional) receives the multipliers.
  void project_velocities(const Coords& q, Coords& v, const Eigen::VectorXd& w,
                          Eigen::VectorXd* mu_out = nullptr) const;

  // Clusters of coupled constraints (connected components), as constraint indices.
  const std::vector<std::vector<int>>& clusters() const { return clusters_; }

 private:
  std::vector<Constraint> list_;
  int n_atoms_ = 0;
  Box box_;
  std::vector<std::vector<int>> clusters_;
  // Cluster-ordered copy of the list with per-cluster solver patterns; shared with the
  // Factorizations made from it, so they stay valid when this object moves.
  struct Layout;
  std::shared_ptr<const Layout> layout_;
  // Scratch for solve_positions, project_velocities, constrain_acceleration, project_onto_kernel,
  // closest_point and pull_back, reused across calls so a step does not allocate. These methods
  // must therefore not run concurrently on the same object.
  struct Workspace;
  std::unique_ptr<Workspace> work_;
  // out = in at every atom, then solve(cluster, its atoms, their count, its outcome) for every
  // cluster, in one parallel region; returns the outcomes combined.
  template <class Solve>
  ClusterSolve copy_then_solve_clusters(const Coords& in, Coords& out, Solve&& solve) const;
};

}  // namespace vimd
