#include "integrators/closest_point.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "engine/constraint_layout.hpp"

namespace vimd {

using constraint_internals::ClusterFactors;
using constraint_internals::kParallelMin;
using constraint_internals::Layout;

ClosestPoint::ClosestPoint(const Constraints& constraints) : constraints_(constraints) {
  if (!constraints.layout()) return;
  const Layout& L = *constraints.layout();
  residual_.setZero(3, L.n_atoms);
  update_.setZero(3, L.n_atoms);
  bonds_.resize(3, L.n_constraints());
  rhs_.resize(L.n_constraints());
  b_.resize(L.n_constraints());
  outcomes_.resize(L.clusters.size());
}

template <class Solve>
ClosestPoint::Outcome ClosestPoint::copy_then_solve_clusters(const Coords& in, Coords& out, Solve&& solve) {
  const Layout& L = *constraints_.layout();
  const int n_atoms = L.n_atoms;
  out.resize(3, n_atoms);
  std::vector<Outcome>& outcome = outcomes_;
  std::fill(outcome.begin(), outcome.end(), Outcome{});
  const int nc = static_cast<int>(L.clusters.size());
#pragma omp parallel if (n_atoms > kParallelMin)
  {
#pragma omp for schedule(static)
    for (int i = 0; i < n_atoms; ++i) out.col(i) = in.col(i);
#pragma omp for schedule(guided)
    for (int c = 0; c < nc; ++c)
      solve(c, L.atoms.data() + L.atom_begin[c], L.atom_begin[c + 1] - L.atom_begin[c], outcome[c]);
  }
  Outcome all;
  for (const auto& c : outcome) {
    all.iterations = std::max(all.iterations, c.iterations);
    all.residual = std::max(all.residual, c.residual);
    all.converged = all.converged && c.converged;
  }
  return all;
}

ClosestPoint::Outcome ClosestPoint::project(const Coords& y, const Eigen::VectorXd& weights, double tolerance,
                                            int max_iterations, Coords& x, Eigen::VectorXd& theta,
                                            Constraints::Factorization& s) {
  if (constraints_.empty()) {
    x = y;
    theta.resize(0);
    return {};
  }
  const Layout& L = *constraints_.layout();
  L.check_coords(y, "y");
  theta.setZero(constraints_.size());
  ClusterFactors& f = s.factors();
  f.factorized = false;
  f.bind(constraints_.layout());
  const double* w = L.weights(weights);
  Coords &r1 = residual_, &dx = update_;
  int singular = -1;
  const Outcome all = copy_then_solve_clusters(y, x, [&](int c, const int* atom, int n_cluster_atoms,
                                                          Outcome& out) {
    const auto& cl = L.clusters[c];
    double* rhs = rhs_.data() + cl.begin;
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
        L.move_along_bond(p, f.r_left.col(p), -theta[L.original[p]], w, r1);
      }
      if (!f.factor(cl, f.r_left, f.r_left, w, true)) {
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
        L.move_along_bond(p, f.r_left.col(p), rhs[p - cl.begin], w, dx);
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

ClosestPoint::Outcome ClosestPoint::pull_back(const Coords& x, const Eigen::VectorXd& theta,
                                              const Constraints::Factorization& s, const Eigen::VectorXd& weights,
                                              const Coords& p, double tolerance, int max_sweeps, Coords& p_hat) {
  if (constraints_.empty()) {
    p_hat = p;
    return {};
  }
  const Layout& L = *constraints_.layout();
  L.check_coords(x, "x");
  L.check_coords(p, "p");
  ClusterFactors& f = s.factors();
  if (!f.factorized || f.layout != constraints_.layout())
    throw std::logic_error("ClosestPoint::pull_back needs project()'s factorisation of these constraints");
  const double* w = L.weights(weights);
  Coords &r1 = residual_, &scaled = update_;
  return copy_then_solve_clusters(p, p_hat, [&](int c, const int* atom, int n_cluster_atoms, Outcome& out) {
    const auto& cl = L.clusters[c];
    double* b = b_.data() + cl.begin;
    double* db = rhs_.data() + cl.begin;
    for (int q = cl.begin; q < cl.end; ++q) {
      bonds_.col(q) = L.bond(x, q);
      b[q - cl.begin] = 0;
    }
    out.converged = false;
    while (out.iterations < max_sweeps) {
      ++out.iterations;
      // r1 = p − (I + Σθ_a H_a W) p̂ − Gᵀb,  r2 = −G W p̂;
      // correction from [[I, Gᵀ], [G W, 0]]: db = S⁻¹(G W r1 − r2), dp = r1 − Gᵀ db.
      for (int k = 0; k < n_cluster_atoms; ++k) {
        scaled.col(atom[k]) = w[atom[k]] * p_hat.col(atom[k]);
        r1.col(atom[k]) = p.col(atom[k]) - p_hat.col(atom[k]);
      }
      for (int q = cl.begin; q < cl.end; ++q) {
        const int i = L.atom_i[q], j = L.atom_j[q];
        const Vec3& r = bonds_.col(q);
        const Vec3 bent = theta[L.original[q]] * (scaled.col(i) - scaled.col(j)) + b[q - cl.begin] * r;
        r1.col(i) -= bent;
        r1.col(j) += bent;
      }
      for (int q = cl.begin; q < cl.end; ++q) {
        const int i = L.atom_i[q], j = L.atom_j[q];
        const Vec3& r = bonds_.col(q);
        db[q - cl.begin] = r.dot(scaled.col(i) - scaled.col(j)) + r.dot(w[i] * r1.col(i) - w[j] * r1.col(j));
      }
      f.solve(cl, db);
      for (int q = cl.begin; q < cl.end; ++q) {
        b[q - cl.begin] += db[q - cl.begin];
        const Vec3 moved = db[q - cl.begin] * bonds_.col(q);
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

}  // namespace vimd
