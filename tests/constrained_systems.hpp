#pragma once
// Test fixtures for the constraint and integrator tests: rigid-water boxes, linear and branched
// bead chains (Systems built directly, no files), and a small smooth potential (harmonic springs
// plus a soft pair repulsion) with forces and Hessian–vector products, standing in for the real
// force field so these tests depend only on engine/ and integrators/.
#include <algorithm>
#include <cmath>
#include <random>
#include <span>
#include <string>
#include <vector>

#include "engine/force_field.hpp"
#include "engine/state.hpp"
#include "engine/system.hpp"

namespace vimd::testing {

// A random unit vector.
inline Vec3 random_direction(std::mt19937_64& rng) {
  std::normal_distribution<double> normal;
  Vec3 u(normal(rng), normal(rng), normal(rng));
  return u.normalized();
}

// Positions wrapped into [0, L) per atom, so molecules straddle the periodic boundaries and every
// bond vector must go through the minimum image.
inline void wrap(const Box& box, Coords& q) {
  for (int i = 0; i < q.cols(); ++i)
    for (int k = 0; k < 3; ++k)
      if (box.length[k] > 0) q(k, i) -= box.length[k] * std::floor(q(k, i) / box.length[k]);
}

inline void add_exclusion(System& s, int i, int j) {
  auto put = [](std::vector<int>& list, int k) {
    auto it = std::lower_bound(list.begin(), list.end(), k);
    if (it == list.end() || *it != k) list.insert(it, k);
  };
  put(s.exclusions[i], j);
  put(s.exclusions[j], i);
}

// Appends an atom; returns its index.
inline int add_atom(System& s, Coords& q, const Vec3& x, double mass, const std::string& name, int molecule) {
  const int n = s.n_atoms();
  s.mass.conservativeResize(n + 1);
  s.mass[n] = mass;
  s.charge.conservativeResize(n + 1);
  s.charge[n] = 0;
  s.atom_names.push_back(name);
  s.residue_names.push_back(name);
  s.residue_numbers.push_back(molecule + 1);
  s.molecule.push_back(molecule);
  s.type.push_back(0);
  s.exclusions.emplace_back();
  q.conservativeResize(3, n + 1);
  q.col(n) = x;
  return n;
}

inline int next_molecule(const System& s) { return s.molecule.empty() ? 0 : s.molecule.back() + 1; }

// One rigid SPC/E-geometry water (O–H 0.1 nm, H–H 0.16330 nm) at `centre`, random orientation,
// as three distance constraints like GROMACS's [ settles ].
inline void add_water(System& s, Coords& q, const Vec3& centre, std::mt19937_64& rng) {
  const double d_oh = 0.1, d_hh = 0.16330;
  const double half_angle = std::asin(0.5 * d_hh / d_oh);
  const Vec3 axis = random_direction(rng);
  Vec3 perp = random_direction(rng);
  perp = (perp - perp.dot(axis) * axis).normalized();
  const int mol = next_molecule(s);
  const int o = add_atom(s, q, centre, 15.9994, "OW", mol);
  const Vec3 h1 = centre + d_oh * (std::cos(half_angle) * axis + std::sin(half_angle) * perp);
  const Vec3 h2 = centre + d_oh * (std::cos(half_angle) * axis - std::sin(half_angle) * perp);
  const int a = add_atom(s, q, h1, 1.008, "HW1", mol);
  const int b = add_atom(s, q, h2, 1.008, "HW2", mol);
  s.constraints.push_back({o, a, d_oh});
  s.constraints.push_back({o, b, d_oh});
  s.constraints.push_back({a, b, d_hh});
  add_exclusion(s, o, a);
  add_exclusion(s, o, b);
  add_exclusion(s, a, b);
}

// n³ waters on a cubic lattice of the given spacing in a periodic box, atoms wrapped.
inline void water_box(int n, double spacing, std::uint64_t seed, System& s, Coords& q) {
  std::mt19937_64 rng(seed);
  s = System{};
  q.resize(3, 0);
  s.box.length = Vec3::Constant(n * spacing);
  for (int x = 0; x < n; ++x)
    for (int y = 0; y < n; ++y)
      for (int z = 0; z < n; ++z) add_water(s, q, spacing * Vec3(x + 0.5, y + 0.5, z + 0.5), rng);
  wrap(s.box, q);
}

// A bead chain with rigid bonds of `bond` nm, grown as a self-avoiding random walk with bond
// angles near 110°, masses 12–16 amu. With `branch_every` > 0, every so many backbone beads
// carry a side branch of `branch_length` beads (atoms with three constraints). Harmonic
// "angle" springs join beads two bonds apart (returned in `springs`), and 1-2/1-3 pairs are
// excluded from the pair repulsion.
inline void add_chain(System& s, Coords& q, int backbone, int branch_every, int branch_length, double bond,
                      const Vec3& start, std::mt19937_64& rng, std::vector<Bond>& springs) {
  std::uniform_real_distribution<double> mass_dist(12.0, 16.0);
  const int mol = next_molecule(s);
  const int first = s.n_atoms();
  const double cos_angle = std::cos(110.0 * M_PI / 180.0);
  // Grows one bead from `from` (whose predecessor is `before`, or -1); keeps away from beads so
  // far placed in this molecule.
  auto grow = [&](int from, int before) {
    for (int attempt = 0;; ++attempt) {
      Vec3 dir = random_direction(rng);
      if (before >= 0) {
        const Vec3 back = (q.col(before) - q.col(from)).normalized();
        Vec3 side = (dir - dir.dot(back) * back).normalized();
        dir = cos_angle * back + std::sqrt(1 - cos_angle * cos_angle) * side;
      }
      const Vec3 x = q.col(from) + bond * dir;
      bool clash = false;
      for (int k = first; k < s.n_atoms() && !clash; ++k) clash = k != from && (q.col(k) - x).norm() < 1.2 * bond;
      if (!clash || attempt > 200) {
        const int n = add_atom(s, q, x, mass_dist(rng), "C", mol);
        s.constraints.push_back({from, n, bond});
        add_exclusion(s, from, n);
        if (before >= 0) {
          add_exclusion(s, before, n);
          springs.push_back({before, n, (q.col(before) - x).norm(), 400.0});
        }
        return n;
      }
    }
  };
  int previous = add_atom(s, q, start, mass_dist(rng), "C", mol);
  int before = -1;
  for (int b = 1; b < backbone; ++b) {
    const int n = grow(previous, before);
    if (branch_every > 0 && b % branch_every == 0 && b + 1 < backbone) {
      int tip = n, behind = previous;
      for (int k = 0; k < branch_length; ++k) {
        const int m = grow(tip, behind);
        behind = tip;
        tip = m;
      }
    }
    before = previous;
    previous = n;
  }
}

// V = Σ_springs ½ k (|r| − r0)² + Σ_pairs ε (1 − r²/rc²)³ (r < rc; pairs not excluded,
// minimum image). Smooth (C²) and cheap; O(N²) pairs are fine for test-sized systems.
class SpringsAndSoftRepulsion : public ForceTerm {
 public:
  SpringsAndSoftRepulsion(const System& system, std::vector<Bond> springs, double epsilon, double cutoff)
      : springs_(std::move(springs)), box_(system.box), epsilon_(epsilon), rc2_(cutoff * cutoff) {
    const int n = system.n_atoms();
    for (int i = 0; i < n; ++i)
      for (int j = i + 1; j < n; ++j)
        if (!std::binary_search(system.exclusions[i].begin(), system.exclusions[i].end(), j)) pairs_.push_back({i, j});
  }
  std::vector<std::string> energy_names() const override { return {"springs", "repulsion"}; }

  // Stateless: its forces are a single point's.
  void add_forces(const Coords& q, Coords& f, std::span<double> energies, const TermEvaluation& = {}) override {
    add_single_point(q, f, energies);
  }
  void add_single_point(const Coords& q, Coords& f, std::span<double> energies) const override {
    double unwanted[2] = {};  // forces only: the energies are computed and dropped
    if (energies.empty()) energies = unwanted;
    for (const Bond& b : springs_) {
      const Vec3 d = box_.minimum_image(q.col(b.i) - q.col(b.j));
      const double r = d.norm();
      energies[0] += 0.5 * b.k * (r - b.length) * (r - b.length);
      const Vec3 force = -b.k * (r - b.length) / r * d;
      f.col(b.i) += force;
      f.col(b.j) -= force;
    }
    for (const auto& [i, j] : pairs_) {
      const Vec3 d = box_.minimum_image(q.col(i) - q.col(j));
      const double x = d.squaredNorm();
      if (x >= rc2_) continue;
      const double s = 1 - x / rc2_;
      energies[1] += epsilon_ * s * s * s;
      const Vec3 force = (6 * epsilon_ / rc2_ * s * s) * d;  // −2 V'(x) d
      f.col(i) += force;
      f.col(j) -= force;
    }
  }

  void add_hessian_vector(const Coords& q, const Coords& u, Coords& out, const TermEvaluation& = {}) override {
    for (const Bond& b : springs_) {
      const Vec3 d = box_.minimum_image(q.col(b.i) - q.col(b.j));
      const double r = d.norm();
      const Vec3 du = u.col(b.i) - u.col(b.j);
      const Vec3 h = b.k * ((1 - b.length / r) * du + (b.length / (r * r * r)) * d.dot(du) * d);
      out.col(b.i) += h;
      out.col(b.j) -= h;
    }
    for (const auto& [i, j] : pairs_) {
      const Vec3 d = box_.minimum_image(q.col(i) - q.col(j));
      const double x = d.squaredNorm();
      if (x >= rc2_) continue;
      const double s = 1 - x / rc2_;
      const double v1 = -3 * epsilon_ / rc2_ * s * s, v2 = 6 * epsilon_ / (rc2_ * rc2_) * s;
      const Vec3 du = u.col(i) - u.col(j);
      const Vec3 h = 2 * v1 * du + 4 * v2 * d.dot(du) * d;
      out.col(i) += h;
      out.col(j) -= h;
    }
  }

 private:
  std::vector<Bond> springs_;
  std::vector<std::pair<int, int>> pairs_;
  Box box_;
  double epsilon_, rc2_;
};

// Maxwell–Boltzmann velocities at temperature T (K), centre-of-mass motion removed.
inline Coords thermal_velocities(const System& s, double temperature, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> normal;
  Coords v(3, s.n_atoms());
  for (int i = 0; i < s.n_atoms(); ++i)
    for (int k = 0; k < 3; ++k) v(k, i) = std::sqrt(kBoltzmann * temperature / s.mass[i]) * normal(rng);
  const Vec3 com = v * s.mass / s.mass.sum();
  v.colwise() -= com;
  return v;
}

}  // namespace vimd::testing
