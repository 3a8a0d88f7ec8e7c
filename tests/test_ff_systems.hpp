#pragma once
// Small water-like test systems built directly in code (no file readers), shared by the force
// field, neighbour list and thread tests.
#include <cmath>
#include <functional>
#include <random>
#include <vector>

#include "engine/force_field.hpp"
#include "engine/system.hpp"
#include "forcefields/settings.hpp"

namespace vimd::testing {

// Three-site molecules: O (charge −0.8476, SPC/E LJ) and two H (+0.4238, a small LJ so the
// type-pair table is exercised), harmonic O–H bonds and H–O–H angle slightly off equilibrium,
// all intramolecular pairs excluded. Oxygens are placed at random with a minimum O–O distance.
// A zero box length makes that direction non-periodic (the molecules then fill `extent`).
struct TestSystem {
  System system;
  Coords q;
};

inline TestSystem water_like_system(int n_molecules, const Vec3& box, std::uint64_t seed,
                                    const Vec3& extent = Vec3::Zero(), double min_oo = 0.27) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  std::normal_distribution<double> normal(0.0, 1.0);
  System s;
  s.title = "water-like test system";
  s.box.length = box;
  s.type_names = {"OW", "HW"};
  s.c6.resize(2, 2);
  s.c12.resize(2, 2);
  const double c6[2] = {0.0026173456, 2.0e-5}, c12[2] = {2.634129e-6, 1.0e-9};
  for (int a = 0; a < 2; ++a)
    for (int b = 0; b < 2; ++b) {
      s.c6(a, b) = std::sqrt(c6[a] * c6[b]);
      s.c12(a, b) = std::sqrt(c12[a] * c12[b]);
    }
  const int n = 3 * n_molecules;
  s.mass.resize(n);
  s.charge.resize(n);
  Coords q(3, n);
  const Vec3 region = (box.array() > 0).select(box, extent);
  std::vector<Vec3> oxygens;
  Box image_box = s.box;
  while (static_cast<int>(oxygens.size()) < n_molecules) {
    Vec3 o(uniform(rng) * region[0], uniform(rng) * region[1], uniform(rng) * region[2]);
    bool ok = true;
    for (const Vec3& p : oxygens)
      if (image_box.minimum_image(o - p).norm() < min_oo) ok = false;
    if (ok) oxygens.push_back(o);
  }
  const double theta0 = 109.47 * M_PI / 180;
  for (int m = 0; m < n_molecules; ++m) {
    const int o = 3 * m;
    Vec3 e1(normal(rng), normal(rng), normal(rng));
    e1.normalize();
    Vec3 e2 = Vec3(normal(rng), normal(rng), normal(rng));
    e2 = (e2 - e2.dot(e1) * e1).normalized();
    const double theta = theta0 + 0.1 * (uniform(rng) - 0.5);
    const double b1 = 0.1 + 0.01 * (uniform(rng) - 0.5), b2 = 0.1 + 0.01 * (uniform(rng) - 0.5);
    q.col(o) = oxygens[m];
    q.col(o + 1) = oxygens[m] + b1 * e1;
    q.col(o + 2) = oxygens[m] + b2 * (std::cos(theta) * e1 + std::sin(theta) * e2);
    for (int k = 0; k < 3; ++k) {
      s.atom_names.push_back(k == 0 ? "OW" : (k == 1 ? "HW1" : "HW2"));
      s.residue_names.push_back("SOL");
      s.residue_numbers.push_back(m + 1);
      s.molecule.push_back(m);
      s.type.push_back(k == 0 ? 0 : 1);
      s.mass[o + k] = k == 0 ? 15.9994 : 1.008;
      s.charge[o + k] = k == 0 ? -0.8476 : 0.4238;
    }
    s.bonds.push_back({o, o + 1, 0.1, 345000.0});
    s.bonds.push_back({o, o + 2, 0.1, 345000.0});
    s.angles.push_back({o + 1, o, o + 2, theta0, 383.0});
  }
  s.exclusions.resize(n);
  for (int m = 0; m < n_molecules; ++m)
    for (int a = 3 * m; a < 3 * m + 3; ++a)
      for (int b = 3 * m; b < 3 * m + 3; ++b)
        if (a != b) s.exclusions[a].push_back(b);
  return {s, q};
}

// Calls f(r) for the distance of every atom pair i < j (minimum image).
inline void for_each_pair_distance(const System& s, const Coords& q, const std::function<void(int, int, double)>& f) {
  for (int i = 0; i < q.cols(); ++i)
    for (int j = i + 1; j < q.cols(); ++j) f(i, j, s.box.minimum_image(q.col(i) - q.col(j)).norm());
}

inline ForceFieldConfig pair_config(const std::string& modifier, const std::string& coulomb, double epsilon_rf = 0,
                                    double cutoff = 0.9, double r_switch = 0.7) {
  ForceFieldConfig c;
  c.cutoff = cutoff;
  c.vdw_modifier = modifier;
  c.vdw_switch = (modifier == "force-switch" || modifier == "potential-switch") ? r_switch : 0.0;
  c.coulomb = coulomb;
  c.epsilon_rf = epsilon_rf;
  c.neighbor_skin = 0.1;  // the list tests' displacements are sized to it, not to the default
  return c;
}

// Energy and forces of a single term at q.
struct TermResult {
  double energy = 0;
  std::vector<double> energies;
  Coords f;
};
inline TermResult evaluate(ForceTerm& term, const Coords& q, const TermEvaluation& how = {}) {
  TermResult r;
  r.energies.assign(term.energy_names().size(), 0.0);
  r.f.setZero(3, q.cols());
  term.add_forces(q, r.f, r.energies, how);
  for (double e : r.energies) r.energy += e;
  return r;
}
inline Coords hessian_vector(ForceTerm& term, const Coords& q, const Coords& u, const TermEvaluation& how = {}) {
  Coords out = Coords::Zero(3, q.cols());
  term.add_hessian_vector(q, u, out, how);
  return out;
}
// A term's searches, prunings and their time.
inline WorkCounters work(const ForceTerm& term) {
  WorkCounters w;
  term.add_work(w);
  return w;
}

// ‖a − b‖ / ‖b‖ (‖b‖ taken as 1 when b is zero).
inline double relative_difference(const Coords& a, const Coords& b) {
  const double scale = b.norm() > 0 ? b.norm() : 1.0;
  return (a - b).norm() / scale;
}


// Chains of `length` atoms, each a random walk of 0.15 nm bonds with bond angles between 53° and
// 127°, started anywhere in a periodic box (so that chains straddle its edges), with every dihedral
// kind on each four consecutive atoms (random parameters) and a 1–4 pair (LJ and charges) for the
// first and last of them. No bonds, angles or exclusions: the terms under test only.
inline TestSystem chain_system(int n_chains, int length, const Vec3& box, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  std::normal_distribution<double> normal(0.0, 1.0);
  System s;
  s.title = "chain test system";
  s.box.length = box;
  const int n = n_chains * length;
  s.mass = Eigen::VectorXd::Constant(n, 12.0);
  s.charge.resize(n);
  s.exclusions.assign(n, {});
  Coords q(3, n);
  const auto random_unit = [&]() { return Vec3(normal(rng), normal(rng), normal(rng)).normalized(); };
  for (int c = 0; c < n_chains; ++c) {
    const int first = c * length;
    q.col(first) = Vec3(uniform(rng) * box[0], uniform(rng) * box[1], uniform(rng) * box[2]);
    Vec3 previous = random_unit();
    for (int a = 1; a < length; ++a) {
      Vec3 next = random_unit();
      while (std::abs(next.dot(previous)) > 0.6) next = random_unit();
      q.col(first + a) = q.col(first + a - 1) + 0.15 * next;
      previous = next;
    }
    for (int a = 0; a < length; ++a) s.charge[first + a] = 0.5 * (uniform(rng) - 0.5);
    for (int a = 0; a + 3 < length; ++a) {
      const int i = first + a, j = i + 1, k = i + 2, l = i + 3;
      s.proper_dihedrals.push_back({i, j, k, l, 2 * M_PI * uniform(rng), 1 + 10 * uniform(rng), 1 + a % 4});
      s.periodic_impropers.push_back({i, j, k, l, M_PI * uniform(rng), 1 + 10 * uniform(rng), 2});
      s.harmonic_impropers.push_back({i, j, k, l, 2 * M_PI * (uniform(rng) - 0.5), 10 + 50 * uniform(rng)});
      RyckaertBellemansDihedral rb{i, j, k, l, {}};
      for (double& cn : rb.c) cn = 10 * (uniform(rng) - 0.5);
      s.rb_dihedrals.push_back(rb);
      s.pairs14.push_back({i, l, 1e-3 * (1 + uniform(rng)), 1e-6 * (1 + uniform(rng)), 0.5 * s.charge[i] * s.charge[l]});
    }
  }
  return {std::move(s), std::move(q)};
}

}  // namespace vimd::testing
