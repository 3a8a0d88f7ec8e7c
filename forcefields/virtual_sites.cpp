#include "forcefields/virtual_sites.hpp"

#include <array>
#include <stdexcept>

#include "forcefields/dihedral_angle.hpp"
#include "forcefields/dual.hpp"

namespace vimd {

namespace {

using Kind = VirtualSite::Kind;

bool is_linear(Kind kind) { return kind == Kind::two || kind == Kind::three; }

template <class T>
T norm3(const T x[3]) {
  using std::sqrt;
  return sqrt(dot3(x, x));
}

// The site's position relative to atom i, from r_ij and r_ik (r_jk = r_ik − r_ij); the formulas
// are System's (VirtualSite).
template <class T>
void site_offset(const VirtualSite& s, const T rij[3], const T rik[3], T out[3]) {
  switch (s.kind) {
    case Kind::two:
      for (int d = 0; d < 3; ++d) out[d] = s.a * rij[d];
      return;
    case Kind::two_fd: {
      const T scale = T{s.a} / norm3(rij);
      for (int d = 0; d < 3; ++d) out[d] = scale * rij[d];
      return;
    }
    case Kind::three:
      for (int d = 0; d < 3; ++d) out[d] = s.a * rij[d] + s.b * rik[d];
      return;
    case Kind::three_fd: {
      T t[3];
      for (int d = 0; d < 3; ++d) t[d] = (1 - s.a) * rij[d] + s.a * rik[d];
      const T scale = T{s.b} / norm3(t);
      for (int d = 0; d < 3; ++d) out[d] = scale * t[d];
      return;
    }
    case Kind::three_fad: {
      T w[3], p[3];
      for (int d = 0; d < 3; ++d) w[d] = rik[d] - rij[d];
      const T c = dot3(rij, w) / dot3(rij, rij);
      for (int d = 0; d < 3; ++d) p[d] = w[d] - c * rij[d];
      const T along = T{s.a} / norm3(rij), across = T{s.b} / norm3(p);
      for (int d = 0; d < 3; ++d) out[d] = along * rij[d] + across * p[d];
      return;
    }
    case Kind::three_out: {
      T n[3];
      cross3(rij, rik, n);
      for (int d = 0; d < 3; ++d) out[d] = s.a * rij[d] + s.b * rik[d] + s.c * n[d];
      return;
    }
  }
}

// g = (scale/|x|) (F − x (x·F)/|x|²): the force F on scale·x/|x| as a force on x.
template <class T>
void unit_vector_gradient(const T x[3], double scale, const T F[3], T g[3]) {
  using std::sqrt;
  const T xx = dot3(x, x);
  const T inverse_norm = T{1.0} / sqrt(xx);
  const T along = dot3(x, F) / xx;
  for (int d = 0; d < 3; ++d) g[d] = scale * inverse_norm * (F[d] - along * x[d]);
}

// (∂offset/∂r_ij)ᵀ F and (∂offset/∂r_ik)ᵀ F: the force F on the site as forces on atoms j and k
// (atom i takes F − gj − gk).
template <class T>
void offset_gradient(const VirtualSite& s, const T rij[3], const T rik[3], const T F[3], T gj[3], T gk[3]) {
  switch (s.kind) {
    case Kind::two:
      for (int d = 0; d < 3; ++d) gj[d] = s.a * F[d], gk[d] = 0.0 * F[d];
      return;
    case Kind::two_fd:
      unit_vector_gradient(rij, s.a, F, gj);
      for (int d = 0; d < 3; ++d) gk[d] = 0.0 * F[d];
      return;
    case Kind::three:
      for (int d = 0; d < 3; ++d) gj[d] = s.a * F[d], gk[d] = s.b * F[d];
      return;
    case Kind::three_fd: {
      T t[3], g[3];
      for (int d = 0; d < 3; ++d) t[d] = (1 - s.a) * rij[d] + s.a * rik[d];
      unit_vector_gradient(t, s.b, F, g);
      for (int d = 0; d < 3; ++d) gj[d] = (1 - s.a) * g[d], gk[d] = s.a * g[d];
      return;
    }
    case Kind::three_fad: {
      // offset = a r/|r| + b p/|p| with r = r_ij, w = r_jk, p = w − c r, c = r·w/r·r.
      T w[3], p[3], g_along[3], g_p[3];
      for (int d = 0; d < 3; ++d) w[d] = rik[d] - rij[d];
      const T rr = dot3(rij, rij);
      const T c = dot3(rij, w) / rr;
      for (int d = 0; d < 3; ++d) p[d] = w[d] - c * rij[d];
      unit_vector_gradient(rij, s.a, F, g_along);
      unit_vector_gradient(p, s.b, F, g_p);
      // Through p: ∂p/∂w = I − r rᵀ/r·r; ∂p/∂r = −c I − r (∂c/∂r)ᵀ, ∂c/∂r = (w − 2c r)/r·r.
      const T r_gp = dot3(rij, g_p) / rr;
      T g_r[3], g_w[3];
      for (int d = 0; d < 3; ++d) {
        g_w[d] = g_p[d] - r_gp * rij[d];
        g_r[d] = g_along[d] - c * g_p[d] - r_gp * (w[d] - 2.0 * c * rij[d]);
      }
      // r = r_ij, w = r_ik − r_ij
      for (int d = 0; d < 3; ++d) gj[d] = g_r[d] - g_w[d], gk[d] = g_w[d];
      return;
    }
    case Kind::three_out: {
      T kf[3], fj[3];
      cross3(rik, F, kf);
      cross3(F, rij, fj);
      for (int d = 0; d < 3; ++d) gj[d] = s.a * F[d] + s.c * kf[d], gk[d] = s.b * F[d] + s.c * fj[d];
      return;
    }
  }
}

// r_ij and r_ik (minimum images) at q; r_ik = 0 for the two-atom kinds.
void displacements(const VirtualSite& s, const Box& box, const Coords& q, double rij[3], double rik[3]) {
  const Vec3 j = box.minimum_image(q.col(s.j) - q.col(s.i));
  const Vec3 k = s.k >= 0 ? box.minimum_image(q.col(s.k) - q.col(s.i)) : Vec3::Zero();
  for (int d = 0; d < 3; ++d) rij[d] = j[d], rik[d] = k[d];
}

// The same with the atoms' motion u as the derivative part.
void displacements(const VirtualSite& s, const Box& box, const Coords& q, const Coords& u, Dual rij[3], Dual rik[3]) {
  double xj[3], xk[3];
  displacements(s, box, q, xj, xk);
  for (int d = 0; d < 3; ++d) {
    rij[d] = {xj[d], u(d, s.j) - u(d, s.i)};
    rik[d] = {xk[d], s.k >= 0 ? u(d, s.k) - u(d, s.i) : 0.0};
  }
}

// Adds gj, gk to atoms j, k and F − gj − gk to atom i.
void add_to_atoms(const VirtualSite& s, const double F[3], const double gj[3], const double gk[3], Coords& f) {
  for (int d = 0; d < 3; ++d) {
    f(d, s.i) += F[d] - gj[d] - gk[d];
    f(d, s.j) += gj[d];
    if (s.k >= 0) f(d, s.k) += gk[d];
  }
}

// Moves the value on site s (a force, or a Hessian–vector product) onto its atoms: Jᵀ applied to it.
// Returns the value moved, for the construction's own second derivative.
std::array<double, 3> spread_site(const VirtualSite& s, const Box& box, const Coords& q, Coords& values) {
  double rij[3], rik[3], gj[3], gk[3];
  std::array<double, 3> value;
  displacements(s, box, q, rij, rik);
  for (int d = 0; d < 3; ++d) value[d] = values(d, s.site);
  offset_gradient(s, rij, rik, value.data(), gj, gk);
  add_to_atoms(s, value.data(), gj, gk, values);
  values.col(s.site).setZero();
  return value;
}

}  // namespace

VirtualSiteConstruction::VirtualSiteConstruction(std::vector<VirtualSite> sites, const Box& box)
    : sites_(std::move(sites)), box_(box) {
  for (const VirtualSite& s : sites_) linear_ = linear_ && is_linear(s.kind);
}

void VirtualSiteConstruction::place(Coords& q) const {
  for (const VirtualSite& s : sites_) {
    double rij[3], rik[3], offset[3];
    displacements(s, box_, q, rij, rik);
    site_offset(s, rij, rik, offset);
    for (int d = 0; d < 3; ++d) q(d, s.site) = q(d, s.i) + offset[d];
  }
}

void VirtualSiteConstruction::tangent(const Coords& q, Coords& u) const {
  for (const VirtualSite& s : sites_) {
    Dual rij[3], rik[3], offset[3];
    displacements(s, box_, q, u, rij, rik);
    site_offset(s, rij, rik, offset);
    for (int d = 0; d < 3; ++d) u(d, s.site) = u(d, s.i) + offset[d].d;
  }
}

void VirtualSiteConstruction::spread(const Coords& q, Coords& f) const {
  // Backwards: a site built from a site hands its force on before that one is spread.
  for (auto s = sites_.rbegin(); s != sites_.rend(); ++s) spread_site(*s, box_, q, f);
}

void VirtualSiteConstruction::spread_hessian(const Coords& q, const Coords& u, const Coords* site_forces,
                                             Coords& hv) const {
  if (!linear_ && !site_forces)
    throw std::logic_error("VirtualSiteConstruction::spread_hessian: nonlinear sites need the forces on the sites");
  Coords forces;  // spread along as hv is, so that a site built from a site sees its whole force
  if (!linear_) forces = *site_forces;
  for (auto s = sites_.rbegin(); s != sites_.rend(); ++s) {
    spread_site(*s, box_, q, hv);
    if (linear_) continue;
    const std::array<double, 3> F = spread_site(*s, box_, q, forces);
    if (is_linear(s->kind)) continue;
    // −(d/du)(Jᵀ F): the change of the spread force as the atoms move along u.
    Dual rij_u[3], rik_u[3], F_u[3], dj[3], dk[3];
    displacements(*s, box_, q, u, rij_u, rik_u);
    for (int d = 0; d < 3; ++d) F_u[d] = {F[d], 0.0};
    offset_gradient(*s, rij_u, rik_u, F_u, dj, dk);
    for (int d = 0; d < 3; ++d) {
      hv(d, s->i) += dj[d].d + dk[d].d;
      hv(d, s->j) -= dj[d].d;
      if (s->k >= 0) hv(d, s->k) -= dk[d].d;
    }
  }
}

}  // namespace vimd
