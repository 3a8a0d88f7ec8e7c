#include "forcefields/harmonic_bond.hpp"

#include <cmath>

namespace vimd {

// The bond lists are O(N) and tiny next to the pair loop, so these loops run serially (no races
// by construction; thread-count independent).

HarmonicBondTerm::HarmonicBondTerm(std::vector<Bond> bonds, const Box& box) : bonds_(std::move(bonds)), box_(box) {}

void HarmonicBondTerm::add_forces(const Coords& q, Coords& f, std::span<double> energies) {
  double energy = 0;
  for (const Bond& b : bonds_) {
    const Vec3 d = box_.minimum_image(q.col(b.i) - q.col(b.j));
    const double r = d.norm();
    const double stretch = r - b.length;
    energy += 0.5 * b.k * stretch * stretch;
    const Vec3 force = (-b.k * stretch / r) * d;  // on i
    f.col(b.i) += force;
    f.col(b.j) -= force;
  }
  energies[0] += energy;
}

void HarmonicBondTerm::add_hessian_vector(const Coords& q, const Coords& u, Coords& out) {
  // Radial pair potential φ(r): Hessian block a I + b d dᵀ with a = φ'/r, b = (φ'' − φ'/r)/r².
  for (const Bond& b : bonds_) {
    const Vec3 d = box_.minimum_image(q.col(b.i) - q.col(b.j));
    const double r2 = d.squaredNorm();
    const double r = std::sqrt(r2);
    const double a = b.k * (r - b.length) / r;
    const double bb = (b.k - a) / r2;
    const Vec3 du = u.col(b.i) - u.col(b.j);
    const Vec3 h = a * du + (bb * d.dot(du)) * d;
    out.col(b.i) += h;
    out.col(b.j) -= h;
  }
}

}  // namespace vimd
