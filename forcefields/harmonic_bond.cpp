#include "forcefields/harmonic_bond.hpp"

#include <cmath>

namespace vimd {

HarmonicBondTerm::HarmonicBondTerm(std::vector<Bond> bonds, const Box& box) : bonds_(std::move(bonds)), box_(box) {}

void HarmonicBondTerm::add_forces_with(BondedLoop& loop, const Coords& q, Coords& f, std::span<double> energies) const {
  const double energy = loop.run(static_cast<int>(bonds_.size()), f, [&](int n, Coords& out) {
    const Bond& b = bonds_[n];
    const Vec3 d = box_.minimum_image(q.col(b.i) - q.col(b.j));
    const double r = d.norm();
    const double stretch = r - b.length;
    const Vec3 force = (-b.k * stretch / r) * d;  // on i
    out.col(b.i) += force;
    out.col(b.j) -= force;
    return 0.5 * b.k * stretch * stretch;
  });
  if (!energies.empty()) energies[0] += energy;
}

void HarmonicBondTerm::add_hessian_vector_with(BondedLoop& loop, const Coords& q, const Coords& u, Coords& out) const {
  // Radial pair potential φ(r): Hessian block a I + b d dᵀ with a = φ'/r, b = (φ'' − φ'/r)/r².
  loop.run(static_cast<int>(bonds_.size()), out, [&](int n, Coords& target) {
    const Bond& b = bonds_[n];
    const Vec3 d = box_.minimum_image(q.col(b.i) - q.col(b.j));
    const double r2 = d.squaredNorm();
    const double r = std::sqrt(r2);
    const double a = b.k * (r - b.length) / r;
    const double bb = (b.k - a) / r2;
    const Vec3 du = u.col(b.i) - u.col(b.j);
    const Vec3 h = a * du + (bb * d.dot(du)) * d;
    target.col(b.i) += h;
    target.col(b.j) -= h;
    return 0.0;
  });
}

}  // namespace vimd
