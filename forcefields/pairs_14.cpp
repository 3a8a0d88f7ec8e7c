#include "forcefields/pairs_14.hpp"

#include <array>
#include <cmath>

namespace vimd {

Pair14Term::Pair14Term(std::vector<Pair14> pairs, const Box& box, const ForceFieldConfig& config)
    : pairs_(std::move(pairs)), box_(box), coulomb_factor_(config.coulomb == "none" ? 0.0 : kCoulomb / config.epsilon_r) {}

void Pair14Term::add_forces_with(BondedLoop& loop, const Coords& q, Coords& f, std::span<double> energies) const {
  const auto [lj, coulomb] = loop.run(static_cast<int>(pairs_.size()), f, [&](int n, Coords& out) {
    const Pair14& p = pairs_[n];
    const Vec3 d = box_.minimum_image(q.col(p.i) - q.col(p.j));
    const double rinv2 = 1 / d.squaredNorm(), rinv = std::sqrt(rinv2), rinv6 = rinv2 * rinv2 * rinv2;
    const double v_lj = (p.c12 * rinv6 - p.c6) * rinv6;
    const double v_coulomb = coulomb_factor_ * p.qq * rinv;
    const double g = (12 * p.c12 * rinv6 - 6 * p.c6) * rinv6 * rinv2 + v_coulomb * rinv2;  // −φ'/r
    out.col(p.i) += g * d;
    out.col(p.j) -= g * d;
    return std::array{v_lj, v_coulomb};
  });
  if (!energies.empty()) {
    energies[0] += lj;
    energies[1] += coulomb;
  }
}

void Pair14Term::add_hessian_vector_with(BondedLoop& loop, const Coords& q, const Coords& u, Coords& out) const {
  // Radial pair potential φ(r): Hessian block a I + b d dᵀ with a = φ'/r, b = (φ'' − φ'/r)/r².
  loop.run(static_cast<int>(pairs_.size()), out, [&](int n, Coords& target) {
    const Pair14& p = pairs_[n];
    const Vec3 d = box_.minimum_image(q.col(p.i) - q.col(p.j));
    const double rinv2 = 1 / d.squaredNorm(), rinv = std::sqrt(rinv2), rinv6 = rinv2 * rinv2 * rinv2;
    const double lj12 = p.c12 * rinv6 * rinv6, lj6 = p.c6 * rinv6, qq = coulomb_factor_ * p.qq * rinv;
    const double a = -(12 * lj12 - 6 * lj6 + qq) * rinv2;
    const double b = (168 * lj12 - 48 * lj6 + 3 * qq) * rinv2 * rinv2;
    const Vec3 du = u.col(p.i) - u.col(p.j);
    const Vec3 h = a * du + (b * d.dot(du)) * d;
    target.col(p.i) += h;
    target.col(p.j) -= h;
    return 0.0;
  });
}

}  // namespace vimd
