#include "forcefields/dihedral_term.hpp"

#include "forcefields/dihedral_angle.hpp"
#include "forcefields/harmonic_improper.hpp"
#include "forcefields/periodic_dihedral.hpp"
#include "forcefields/ryckaert_bellemans.hpp"

namespace vimd {

namespace {

template <class T>
T energy_of(const PeriodicDihedral& t, T phi, T& dv) { return periodic_dihedral_energy(t, phi, dv); }
template <class T>
T energy_of(const RyckaertBellemansDihedral& t, T phi, T& dv) { return ryckaert_bellemans_energy(t, phi, dv); }
template <class T>
T energy_of(const HarmonicImproper& t, T phi, T& dv) { return harmonic_improper_energy(t, phi, dv); }

// V and its gradient grad[atom] = ∂V/∂x (atoms i, j, k, l); zero where φ is undefined.
template <class T, class Item>
T dihedral_energy_gradient(const Item& t, const T a[3], const T b[3], const T c[3], T grad[4][3]) {
  T phi, dphi[4][3];
  const bool defined = dihedral_angle(a, b, c, phi, dphi);
  T dv_dphi;
  const T v = energy_of(t, phi, dv_dphi);
  for (int atom = 0; atom < 4; ++atom)
    for (int d = 0; d < 3; ++d) grad[atom][d] = defined ? dv_dphi * dphi[atom][d] : T{};
  return v;
}

struct Geometry {
  Vec3 a, b, c;  // x_i − x_j, x_k − x_j, x_k − x_l
};

template <class Item>
Geometry geometry(const Item& t, const Coords& x, const Box& box) {
  return {box.minimum_image(x.col(t.i) - x.col(t.j)), box.minimum_image(x.col(t.k) - x.col(t.j)),
          box.minimum_image(x.col(t.k) - x.col(t.l))};
}

template <class Item>
double add_forces_of(BondedLoop& loop, const std::vector<Item>& items, const Coords& q, const Box& box, Coords& f) {
  return loop.run(static_cast<int>(items.size()), f, [&](int n, Coords& out) {
    const Item& t = items[n];
    const Geometry g = geometry(t, q, box);
    const double a[3] = {g.a[0], g.a[1], g.a[2]}, b[3] = {g.b[0], g.b[1], g.b[2]}, c[3] = {g.c[0], g.c[1], g.c[2]};
    double grad[4][3];
    const double energy = dihedral_energy_gradient(t, a, b, c, grad);
    const int atoms[4] = {t.i, t.j, t.k, t.l};
    for (int atom = 0; atom < 4; ++atom)
      for (int d = 0; d < 3; ++d) out(d, atoms[atom]) -= grad[atom][d];
    return energy;
  });
}

// The gradient on dual numbers whose derivative parts are u's differences along the same vectors.
template <class Item>
void add_hessian_vector_of(BondedLoop& loop, const std::vector<Item>& items, const Coords& q, const Coords& u,
                           const Box& box, Coords& out) {
  loop.run(static_cast<int>(items.size()), out, [&](int n, Coords& target) {
    const Item& t = items[n];
    const Geometry g = geometry(t, q, box);
    const Vec3 ua = u.col(t.i) - u.col(t.j), ub = u.col(t.k) - u.col(t.j), uc = u.col(t.k) - u.col(t.l);
    Dual a[3], b[3], c[3];
    for (int d = 0; d < 3; ++d) {
      a[d] = {g.a[d], ua[d]};
      b[d] = {g.b[d], ub[d]};
      c[d] = {g.c[d], uc[d]};
    }
    Dual grad[4][3];
    dihedral_energy_gradient(t, a, b, c, grad);
    const int atoms[4] = {t.i, t.j, t.k, t.l};
    for (int atom = 0; atom < 4; ++atom)
      for (int d = 0; d < 3; ++d) target(d, atoms[atom]) += grad[atom][d].d;
    return 0.0;
  });
}

}  // namespace

DihedralTerm::DihedralTerm(const System& system)
    : proper_(system.proper_dihedrals),
      periodic_impropers_(system.periodic_impropers),
      ryckaert_bellemans_(system.rb_dihedrals),
      harmonic_impropers_(system.harmonic_impropers),
      box_(system.box) {}

void DihedralTerm::add_forces_with(BondedLoop& loop, const Coords& q, Coords& f, std::span<double> energies) const {
  const double proper = add_forces_of(loop, proper_, q, box_, f) + add_forces_of(loop, ryckaert_bellemans_, q, box_, f);
  const double improper =
      add_forces_of(loop, harmonic_impropers_, q, box_, f) + add_forces_of(loop, periodic_impropers_, q, box_, f);
  if (!energies.empty()) {
    energies[0] += proper;
    energies[1] += improper;
  }
}

void DihedralTerm::add_hessian_vector_with(BondedLoop& loop, const Coords& q, const Coords& u, Coords& out) const {
  add_hessian_vector_of(loop, proper_, q, u, box_, out);
  add_hessian_vector_of(loop, ryckaert_bellemans_, q, u, box_, out);
  add_hessian_vector_of(loop, harmonic_impropers_, q, u, box_, out);
  add_hessian_vector_of(loop, periodic_impropers_, q, u, box_, out);
}

}  // namespace vimd
