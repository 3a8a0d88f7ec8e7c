#include "forcefields/harmonic_angle.hpp"

#include <cmath>

#include "forcefields/dual.hpp"

namespace vimd {

namespace {

using std::atan2;
using std::sqrt;

// With a = r_i − r_j, b = r_k − r_j: θ = atan2(|a × b|, a·b) (accurate near 0 and π), and
// gradient of V = ½ k (θ − θ0)²: ∂V/∂a = k (θ − θ0) ((a·b) a/|a|² − b)/|a × b|, likewise for b.
template <class T>
T angle_energy_gradient(const T a[3], const T b[3], double k, double theta0, T grad_a[3], T grad_b[3]) {
  const T ab = a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
  const T aa = a[0] * a[0] + a[1] * a[1] + a[2] * a[2];
  const T bb = b[0] * b[0] + b[1] * b[1] + b[2] * b[2];
  const T c[3] = {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
  const T s = sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]);
  const T dtheta = atan2(s, ab) - theta0;
  const T scale = k * dtheta / s;
  for (int m = 0; m < 3; ++m) {
    grad_a[m] = scale * ((ab / aa) * a[m] - b[m]);
    grad_b[m] = scale * ((ab / bb) * b[m] - a[m]);
  }
  return 0.5 * k * dtheta * dtheta;
}

}  // namespace

HarmonicAngleTerm::HarmonicAngleTerm(std::vector<Angle> angles, const Box& box)
    : angles_(std::move(angles)), box_(box) {}

void HarmonicAngleTerm::add_forces_with(BondedLoop& loop, const Coords& q, Coords& f,
                                        std::span<double> energies) const {
  const double energy = loop.run(static_cast<int>(angles_.size()), f, [&](int n, Coords& out) {
    const Angle& t = angles_[n];
    const Vec3 va = box_.minimum_image(q.col(t.i) - q.col(t.j));
    const Vec3 vb = box_.minimum_image(q.col(t.k) - q.col(t.j));
    const double a[3] = {va[0], va[1], va[2]}, b[3] = {vb[0], vb[1], vb[2]};
    double ga[3], gb[3];
    const double energy = angle_energy_gradient(a, b, t.force_constant, t.theta0, ga, gb);
    for (int m = 0; m < 3; ++m) {
      out(m, t.i) -= ga[m];
      out(m, t.k) -= gb[m];
      out(m, t.j) += ga[m] + gb[m];
    }
    return energy;
  });
  if (!energies.empty()) energies[0] += energy;
}

void HarmonicAngleTerm::add_hessian_vector_with(BondedLoop& loop, const Coords& q, const Coords& u, Coords& out) const {
  loop.run(static_cast<int>(angles_.size()), out, [&](int n, Coords& target) {
    const Angle& t = angles_[n];
    const Vec3 va = box_.minimum_image(q.col(t.i) - q.col(t.j));
    const Vec3 vb = box_.minimum_image(q.col(t.k) - q.col(t.j));
    const Vec3 ua = u.col(t.i) - u.col(t.j), ub = u.col(t.k) - u.col(t.j);
    const Dual a[3] = {{va[0], ua[0]}, {va[1], ua[1]}, {va[2], ua[2]}};
    const Dual b[3] = {{vb[0], ub[0]}, {vb[1], ub[1]}, {vb[2], ub[2]}};
    Dual ga[3], gb[3];
    angle_energy_gradient(a, b, t.force_constant, t.theta0, ga, gb);
    for (int m = 0; m < 3; ++m) {
      target(m, t.i) += ga[m].d;
      target(m, t.k) += gb[m].d;
      target(m, t.j) -= ga[m].d + gb[m].d;
    }
    return 0.0;
  });
}

}  // namespace vimd
