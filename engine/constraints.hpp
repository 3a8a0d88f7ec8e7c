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

namespace constraint_internals {  // engine/constraint_layout.hpp
struct Layout;
struct ClusterFactors;
struct Workspace;
}  // namespace constraint_internals

// The half-step velocity a position stage leaves, for solve_positions: v_i = (q_i − q_ref,i)·(1/h)
// for every constrained atom i, written as its cluster is solved (the other atoms keep theirs: the
// drift q = q_ref + h v already carried them). A product, not a quotient: SETTLE's nine divisions
// a molecule cost as much as its rotation.
struct StepVelocity {
  Coords& v;
  double h;
};

// Geometry, factorisation and the solves with S in engine/constraints.cpp, the SHAKE/RATTLE
// stages (solve_positions, project_velocities) in engine/shake_rattle_solve.cpp, their rigid-water
// special case SETTLE in engine/settle.cpp. An empty weights vector means all ones.
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
  // out += G(q)ᵀ λ, scaled per atom by the weights when given (out += W Gᵀλ)
  void add_GT(const Coords& q, const Eigen::VectorXd& lambda, Coords& out,
              const Eigen::VectorXd& weights = Eigen::VectorXd()) const;
  // out += Σ_a c_a H_a y, i.e. c_a (y_i − y_j) at i and −c_a (y_i − y_j) at j (W-scaled if weights given)
  void add_H(const Eigen::VectorXd& c, const Coords& y, Coords& out,
             const Eigen::VectorXd& weights = Eigen::VectorXd()) const;

  // S = G(q_left) W G(q_right)ᵀ with W = diag(weights), per atom (inverse masses, or ones), factorised
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
    // The factors cluster by cluster, for solvers that include engine/constraint_layout.hpp.
    constraint_internals::ClusterFactors& factors() const { return *impl_; }

   private:
    std::unique_ptr<constraint_internals::ClusterFactors> impl_;
  };
  void factorize(const Coords& q_left, const Coords& q_right, const Eigen::VectorXd& weights,
                 Factorization& out) const;

  // The two solves of the constrained dynamics, each in one pass over the clusters (bond vectors,
  // S, solve and scatter per cluster) rather than the four of apply_G, factorize, solve and add_GT.
  // Same arithmetic as that sequence.
  //
  // a ← a + W Gᵀλ with S λ = −G a − D²g(v,v), S = G W Gᵀ at q (factorised into `s`, symmetric):
  // the index-1 acceleration when a enters as W f. D²g_a(v,v) = |v_i − v_j|² (no minimum image).
  void constrain_acceleration(const Coords& q, const Coords& v, const Eigen::VectorXd& weights, Coords& a,
                              Eigen::VectorXd& lambda, Factorization& s) const;
  // u ← u − W Gᵀμ with μ = S⁻¹ G u, G and S = G W Gᵀ those `s` was factorised at (symmetric, with
  // these weights): the W-orthogonal projection of u onto ker G. μ into mu.
  void project_onto_kernel(const Factorization& s, const Eigen::VectorXd& weights, Coords& u,
                           Eigen::VectorXd& mu) const;

  // SHAKE/RATTLE position stage: q ← q + W G(q_ref)ᵀ λ with λ chosen so that every
  // constraint holds to a relative deviation | |r_a| − d_a | / d_a ≤ tolerance (the measure of
  // max_relative_deviation). Newton on λ per cluster (exact Jacobian G(q) W G(q_ref)ᵀ for small
  // and dense clusters; chains start from a factorisation of the symmetric S(q_ref)). Returns the
  // iterations taken (maximum over clusters); throws ConvergenceError(step, iterations, worst
  // relative deviation, worst constraint with its 1-based atoms) when it cannot. lambda_out
  // (optional) receives the accumulated multipliers, max_deviation_out (optional) the final
  // maximum relative deviation (saves a max_relative_deviation pass). Rigid water goes through
  // SETTLE where the multipliers are not asked for. velocity (optional): see StepVelocity.
  int solve_positions(const Coords& q_ref, Coords& q, const Eigen::VectorXd& weights, double tolerance, long step,
                      int max_iterations = 500, Eigen::VectorXd* lambda_out = nullptr,
                      double* max_deviation_out = nullptr, const StepVelocity* velocity = nullptr) const;
  // v ← v − W Gᵀ S⁻¹ G v at q: the W-orthogonal projection onto the tangent space
  // (the RATTLE velocity stage when W = M⁻¹). mu_out (optional) receives the multipliers.
  void project_velocities(const Coords& q, Coords& v, const Eigen::VectorXd& weights,
                          Eigen::VectorXd* mu_out = nullptr) const;

  // Clusters of coupled constraints (connected components), as constraint indices.
  const std::vector<std::vector<int>>& clusters() const { return clusters_; }
  // The cluster-ordered layout (engine/constraint_layout.hpp), for solvers that work cluster by
  // cluster; null for a default-constructed object.
  const std::shared_ptr<const constraint_internals::Layout>& layout() const { return layout_; }

 private:
  std::vector<Constraint> list_;
  Box box_;
  std::vector<std::vector<int>> clusters_;
  // Cluster-ordered copy of the list with per-cluster solver patterns; shared with the
  // Factorizations made from it, so they stay valid when this object moves.
  std::shared_ptr<const constraint_internals::Layout> layout_;
  // Scratch for the solves, reused across calls so a step does not allocate. The solves must
  // therefore not run concurrently on the same object.
  std::unique_ptr<constraint_internals::Workspace> work_;
};

}  // namespace vimd
