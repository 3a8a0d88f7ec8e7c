#pragma once
// Finite-difference checks of a force term: forces against fourth-order central differences of
// the energy, Hessian–vector products against the same of the forces.
#include <gtest/gtest.h>

#include <random>
#include <string>

#include "test_ff_systems.hpp"

namespace vimd::testing {

// Fourth-order central differences: truncation O(h⁴), so 1e-6 relative is a real check.
constexpr double kStep = 1e-5;

inline Coords finite_difference_forces(ForceTerm& term, const Coords& q, double step = kStep) {
  Coords f(3, q.cols());
  for (int i = 0; i < q.cols(); ++i)
    for (int k = 0; k < 3; ++k) {
      auto energy = [&](double h) {
        Coords p = q;
        p(k, i) += h;
        return evaluate(term, p).energy;
      };
      f(k, i) = -(-energy(2 * step) + 8 * energy(step) - 8 * energy(-step) + energy(-2 * step)) / (12 * step);
    }
  return f;
}

// ∇²V u = −d/dε F(q + ε u).
inline Coords finite_difference_hessian_vector(ForceTerm& term, const Coords& q, const Coords& u,
                                              double step = kStep) {
  auto force = [&](double h) { return evaluate(term, q + h * u).f; };
  return -(-force(2 * step) + 8 * force(step) - 8 * force(-step) + force(-2 * step)) / (12 * step);
}

inline Coords random_direction(int n, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  Coords u(3, n);
  for (int i = 0; i < n; ++i)
    for (int k = 0; k < 3; ++k) u(k, i) = normal(rng);
  return u;
}

// `step`: the differences' step (nm), small against the scale on which the term changes.
inline void expect_derivatives_match(ForceTerm& term, const Coords& q, const std::string& what,
                                     double step = kStep) {
  const auto at_q = evaluate(term, q);
  ASSERT_GT(at_q.f.norm(), 0.0) << what << ": forces vanish, the check would be empty";
  const Coords fd = finite_difference_forces(term, q, step);
  EXPECT_LT(relative_difference(at_q.f, fd), 1e-6) << what << ": forces vs finite differences";
  const Coords u = random_direction(static_cast<int>(q.cols()), 7);
  const Coords hu = hessian_vector(term, q, u);
  ASSERT_GT(hu.norm(), 0.0) << what;
  EXPECT_LT(relative_difference(hu, finite_difference_hessian_vector(term, q, u, step)), 1e-6)
      << what << ": Hessian-vector product vs finite differences";
}

}  // namespace vimd::testing
