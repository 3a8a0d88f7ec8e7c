#pragma once
// Projection onto the constraint manifold Q (docs/variational-integrator.md, "Projection onto the
// constraint manifold") and the tangent-space projections the variational integrator needs.
//   P(y) = x  where  y = x + W⁻¹G(x)ᵀθ,  g(x) = 0     (W = I "euclidean", or W = M "mass")
//   pull-back p̂ = p·DP(y):  [[I + Σθ_a H_a W⁻¹, Gᵀ], [G W⁻¹, 0]] [p̂; b] = [p; 0]
#include <string>

#include "engine/constraints.hpp"
#include "integrators/closest_point.hpp"

namespace vimd {

// The W-orthogonal projection u ← u − W⁻¹Gᵀ(G W⁻¹ Gᵀ)⁻¹G u onto ker G(q). The factorisation is
// kept, so several projections at the same q cost one factorisation.
class TangentProjector {
 public:
  TangentProjector(const Constraints& constraints, Eigen::VectorXd inverse_weights);
  void set_point(const Coords& q);
  // u ← projection of u; mu (optional) receives the multipliers (G W⁻¹ Gᵀ)⁻¹ G u.
  void apply(Coords& u, Eigen::VectorXd* mu = nullptr);

 private:
  const Constraints& constraints_;
  Eigen::VectorXd inverse_weights_;
  Constraints::Factorization factor_;
  Eigen::VectorXd mu_;
};

struct ProjectedPoint {
  Coords x;                            // P(y)
  Eigen::VectorXd theta;               // y = x + W⁻¹G(x)ᵀθ
  Constraints::Factorization s_factor; // G W⁻¹ Gᵀ at (the last Newton iterate before) x
  int iterations = 0;
};

// InputError unless `kind` is "euclidean" or "mass".
void check_projection_kind(const std::string& kind);

class Projection {
 public:
  // `kind` is "euclidean" (W = I) or "mass" (W = M).
  Projection(const Constraints& constraints, const Eigen::VectorXd& inverse_mass, const std::string& kind);

  // Newton with the Jacobian [[I, W⁻¹Gᵀ], [G, 0]] at the current iterate (the Σθ_aH_a block is
  // O(θ) and dropped, so convergence is linear with rate O(|θ|), G refreshed every iteration),
  // each cluster of constraints on its own (ClosestPoint::project).
  // Throws ConvergenceError("projection onto the constraints", step, ...) when it cannot converge.
  void project(const Coords& y, ProjectedPoint& out, long step);
  // p_hat = p·DP(y) at a point from project(); iterated to round-off with G W⁻¹ Gᵀ as the
  // preconditioner (two sweeps usually do, θ being tiny after an RK step).
  void pull_back(const ProjectedPoint& point, const Coords& p, Coords& p_hat, long step);

  const Eigen::VectorXd& inverse_weights() const { return inverse_weights_; }

 private:
  ClosestPoint closest_point_;
  Eigen::VectorXd inverse_weights_;  // W⁻¹ per atom
  double length_scale_ = 1;          // shortest constraint length, for the stopping test
};

}  // namespace vimd
