#pragma once
// The dihedral angle φ of atoms i-j-k-l and its gradient, in GROMACS's convention (dih_angle in
// listed_forces/bonded.cpp): with a = x_i − x_j, b = x_k − x_j, c = x_k − x_l (minimum images),
// m = a × b and n = b × c, φ = sign(a·n) ∠(m, n) in [−π, π], 0 for cis, ±π for trans. Written as
// atan2(|b| a·n, m·n) (|m × n| = |b| |a·n|), which is smooth wherever φ is defined. Gradient:
//   ∂φ/∂x_i = |b| m/|m|²,   ∂φ/∂x_l = −|b| n/|n|²,
//   ∂φ/∂x_j = (p − 1) ∂φ/∂x_i − q ∂φ/∂x_l,   ∂φ/∂x_k = (q − 1) ∂φ/∂x_l − p ∂φ/∂x_i,
// with p = a·b/|b|², q = c·b/|b|². Templates on the number type (double, Dual).
#include <cmath>
#include <limits>

#include "forcefields/dual.hpp"

namespace vimd {

template <class T>
T dot3(const T x[3], const T y[3]) {
  return x[0] * y[0] + x[1] * y[1] + x[2] * y[2];
}

template <class T>
void cross3(const T x[3], const T y[3], T out[3]) {
  out[0] = x[1] * y[2] - x[2] * y[1];
  out[1] = x[2] * y[0] - x[0] * y[2];
  out[2] = x[0] * y[1] - x[1] * y[0];
}

// Sets φ and, where the torsion is defined, grad[atom][xyz] = ∂φ/∂x (atoms i, j, k, l), and
// returns true. Where three of the atoms are on a line (|m|² or |n|² at most ε |b|², GROMACS's
// tolerance), the planes, and so φ, are undefined: φ is what atan2 gives (GROMACS's value) and
// false is returned; the caller then adds no force, as GROMACS does.
template <class T>
bool dihedral_angle(const T a[3], const T b[3], const T c[3], T& phi, T grad[4][3]) {
  using std::atan2;
  using std::sqrt;
  T m[3], n[3];
  cross3(a, b, m);
  cross3(b, c, n);
  const T mm = dot3(m, m), nn = dot3(n, n), bb = dot3(b, b);
  const T b_norm = sqrt(bb);
  phi = atan2(b_norm * dot3(a, n), dot3(m, n));
  const double tolerance = value_of(bb) * std::numeric_limits<double>::epsilon();
  if (!(value_of(mm) > tolerance && value_of(nn) > tolerance)) return false;
  const T p = dot3(a, b) / bb, q = dot3(c, b) / bb;
  const T gi = b_norm / mm, gl = b_norm / nn;
  for (int d = 0; d < 3; ++d) {
    grad[0][d] = gi * m[d];
    grad[3][d] = -(gl * n[d]);
    grad[1][d] = (p - 1.0) * grad[0][d] - q * grad[3][d];
    grad[2][d] = (q - 1.0) * grad[3][d] - p * grad[0][d];
  }
  return true;
}

}  // namespace vimd
