#pragma once
// The closest-point projection x = P(y) onto the constraint manifold and its pull-back
// p̂ = p·DP(y) (docs/variational-integrator.md, "Projection onto the constraint manifold"), each
// cluster of coupled constraints iterated on its own (its atoms are no other cluster's) until its
// update is at most `tolerance` (max abs over its atoms); atoms under no constraint are copied.
// W = diag(weights). Projection (projection.hpp) sets the tolerances and reports failures.
#include <vector>

#include "engine/constraints.hpp"

namespace vimd {

class ClosestPoint {
 public:
  struct Outcome {
    int iterations = 0;   // the most any cluster took
    double residual = 0;  // the largest last update
    bool converged = true;
  };

  // Keeps a reference: `constraints` must outlive this object.
  explicit ClosestPoint(const Constraints& constraints);

  // y = x + W G(x)ᵀθ, g(x) = 0, by Newton with the Jacobian [[I, WGᵀ], [G, 0]] at the iterate.
  // θ into theta; S = G W Gᵀ at each cluster's last iterate before x into s.
  Outcome project(const Coords& y, const Eigen::VectorXd& weights, double tolerance, int max_iterations, Coords& x,
                  Eigen::VectorXd& theta, Constraints::Factorization& s);
  // p̂ = p·DP(y) at x = P(y), with θ and s from project():
  // [[I + Σθ_a H_a W, Gᵀ], [G W, 0]] [p̂; b] = [p; 0], by sweeps preconditioned with s.
  Outcome pull_back(const Coords& x, const Eigen::VectorXd& theta, const Constraints::Factorization& s,
                    const Eigen::VectorXd& weights, const Coords& p, double tolerance, int max_sweeps,
                    Coords& p_hat);

 private:
  // out = in at every atom, then solve(cluster, its atoms, their count, its outcome) for every
  // cluster, in one parallel region; returns the outcomes combined.
  template <class Solve>
  Outcome copy_then_solve_clusters(const Coords& in, Coords& out, Solve&& solve);

  const Constraints& constraints_;
  // Scratch, reused so that a step does not allocate. Per atom: the residual and the update.
  Coords residual_, update_;
  // Per constraint, cluster order: pull_back's bond vectors at x, the right-hand side or
  // correction of a cluster's solve, pull_back's multipliers b.
  Coords bonds_;
  Eigen::VectorXd rhs_, b_;
  std::vector<Outcome> outcomes_;  // per cluster
};

}  // namespace vimd
