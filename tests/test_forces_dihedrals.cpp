// The dihedral term, every kind: the angle as GROMACS defines it, energies against the manual's
// formulas, derivatives against finite differences, and the wrap-around and collinear cases.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "forcefields/dihedral_angle.hpp"
#include "forcefields/dihedral_term.hpp"
#include "test_forces_common.hpp"

namespace vimd {
namespace {

using testing::evaluate;
using testing::expect_derivatives_match;
using testing::hessian_vector;
using testing::random_direction;

// GROMACS's dihedral angle (dih_angle): the angle between m = a × b and n = b × c, signed as a·n.
double gromacs_dihedral(const Vec3& xi, const Vec3& xj, const Vec3& xk, const Vec3& xl) {
  const Vec3 a = xi - xj, b = xk - xj, c = xk - xl;
  const Vec3 m = a.cross(b), n = b.cross(c);
  const double angle = std::atan2(m.cross(n).norm(), m.dot(n));
  return a.dot(n) < 0 ? -angle : angle;
}

double dihedral_of(const Coords& q, const Box& box, int i, int j, int k, int l) {
  const Vec3 xj = q.col(j);
  return gromacs_dihedral(xj + box.minimum_image(q.col(i) - xj), xj, xj + box.minimum_image(q.col(k) - xj),
                          xj + box.minimum_image(q.col(k) - xj) - box.minimum_image(q.col(k) - q.col(l)));
}

TEST(DihedralAngle, MatchesGromacsDefinition) {
  const auto phi = [](const Vec3& xi, const Vec3& xj, const Vec3& xk, const Vec3& xl) {
    const Vec3 a = xi - xj, b = xk - xj, c = xk - xl;
    double angle, grad[4][3];
    EXPECT_TRUE(dihedral_angle(a.data(), b.data(), c.data(), angle, grad));
    return angle;
  };
  // cis 0, trans ±π, and the sign of a quarter turn (IUPAC: clockwise seen along j→k is positive).
  EXPECT_NEAR(phi({1, 1, 0}, {0, 0, 0}, {0, 0, 1}, {1, 1, 1}), 0.0, 1e-15);
  EXPECT_NEAR(std::abs(phi({1, 0, 0}, {0, 0, 0}, {0, 0, 1}, {-1, 0, 1})), M_PI, 1e-15);
  EXPECT_NEAR(phi({1, 0, 0}, {0, 0, 0}, {0, 0, 1}, {0, 1, 1}), M_PI / 2, 1e-15);
  EXPECT_NEAR(phi({1, 0, 0}, {0, 0, 0}, {0, 0, 1}, {0, -1, 1}), -M_PI / 2, 1e-15);
  std::mt19937_64 rng(4);
  std::normal_distribution<double> normal(0.0, 1.0);
  for (int trial = 0; trial < 100; ++trial) {
    Vec3 x[4];
    for (Vec3& p : x) p = Vec3(normal(rng), normal(rng), normal(rng));
    EXPECT_NEAR(phi(x[0], x[1], x[2], x[3]), gromacs_dihedral(x[0], x[1], x[2], x[3]), 1e-12) << trial;
  }
}

// One kind at a time: the term's energy column, the energy against a direct sum of the GROMACS
// manual's formula, and the derivative checks, with chains straddling the box edges.
TEST(DihedralTerm, EveryKindMatchesItsDefinitionAndFiniteDifferences) {
  auto [full, q] = testing::chain_system(12, 6, Vec3(1.5, 1.6, 1.7), 31);
  const Box& box = full.box;
  const auto only = [&](auto member) {
    System s;
    s.box = box;
    s.*member = full.*member;
    return s;
  };
  const auto phi = [&](const auto& t) { return dihedral_of(q, box, t.i, t.j, t.k, t.l); };
  struct Kind {
    System system;
    int column;  // 0 dihedrals, 1 impropers
    double expected;
    const char* what;
  };
  std::vector<Kind> kinds;
  double v = 0;
  for (const PeriodicDihedral& t : full.proper_dihedrals)
    v += t.force_constant * (1 + std::cos(t.multiplicity * phi(t) - t.phi_s));
  kinds.push_back({only(&System::proper_dihedrals), 0, v, "proper (types 1, 9)"});
  v = 0;
  for (const RyckaertBellemansDihedral& t : full.rb_dihedrals)
    for (int n = 0; n < 6; ++n) v += t.c[n] * std::pow(std::cos(phi(t) - M_PI), n);
  kinds.push_back({only(&System::rb_dihedrals), 0, v, "Ryckaert-Bellemans (types 3, 5)"});
  v = 0;
  for (const HarmonicImproper& t : full.harmonic_impropers) {
    const double d = std::remainder(phi(t) - t.xi0, 2 * M_PI);
    v += 0.5 * t.force_constant * d * d;
  }
  kinds.push_back({only(&System::harmonic_impropers), 1, v, "harmonic improper (type 2)"});
  v = 0;
  for (const PeriodicDihedral& t : full.periodic_impropers)
    v += t.force_constant * (1 + std::cos(t.multiplicity * phi(t) - t.phi_s));
  kinds.push_back({only(&System::periodic_impropers), 1, v, "periodic improper (type 4)"});
  for (Kind& kind : kinds) {
    kind.system.mass = full.mass;
    DihedralTerm term(kind.system);
    EXPECT_EQ(term.energy_names(), (std::vector<std::string>{"dihedrals", "impropers"}));
    const auto result = evaluate(term, q);
    EXPECT_NEAR(result.energies[kind.column], kind.expected, 1e-11 * std::abs(kind.expected)) << kind.what;
    EXPECT_EQ(result.energies[1 - kind.column], 0.0) << kind.what;
    expect_derivatives_match(term, q, kind.what);
  }
  DihedralTerm all(full);
  const auto together = evaluate(all, q);
  EXPECT_NEAR(together.energies[0], kinds[0].expected + kinds[1].expected, 1e-11 * std::abs(together.energies[0]));
  EXPECT_NEAR(together.energies[1], kinds[2].expected + kinds[3].expected, 1e-11 * std::abs(together.energies[1]));
  expect_derivatives_match(all, q, "all dihedral kinds");
}

// A harmonic improper half a turn from ξ0 − π takes ξ − ξ0 in [−π, π) as GROMACS: ξ0 = 179°
// and ξ = −179° are 2° apart, not 358°.
TEST(DihedralTerm, HarmonicImproperWrapsAroundTheHalfTurn) {
  System s;
  s.box.length = Vec3::Zero();
  const double xi = -179.0 * M_PI / 180;
  Coords q(3, 4);
  q.col(0) = Vec3(0.1, 0, 0);
  q.col(1) = Vec3(0, 0, 0);
  q.col(2) = Vec3(0, 0, 0.15);
  q.col(3) = Vec3(0.1 * std::cos(xi), 0.1 * std::sin(xi), 0.15);
  ASSERT_NEAR(dihedral_of(q, s.box, 0, 1, 2, 3), xi, 1e-12);
  s.harmonic_impropers = {{0, 1, 2, 3, 179.0 * M_PI / 180, 100.0}};
  DihedralTerm term(s);
  const double d = 2.0 * M_PI / 180;
  EXPECT_NEAR(evaluate(term, q).energies[1], 0.5 * 100 * d * d, 1e-12);
  expect_derivatives_match(term, q, "harmonic improper across the half turn");
}

// Near 180° at j or k the torsion changes fast but is defined: exact derivatives (checked with
// differences of a step small against l's distance from the line j-k). With three atoms
// exactly on a line it is undefined: GROMACS then takes φ = 0 (atan2(0, 0)) for the energy and adds
// no force (do_dih_fup's tolerance); so does vimd, and the Hessian-vector product is zero too.
TEST(DihedralTerm, NearlyAndExactlyCollinearAtoms) {
  System s;
  s.box.length = Vec3::Zero();
  s.proper_dihedrals = {{0, 1, 2, 3, 0.3, 5.0, 3}};
  s.rb_dihedrals = {{0, 1, 2, 3, {1.0, -2.0, 3.0, 0.5, -1.5, 0.7}}};
  s.harmonic_impropers = {{0, 1, 2, 3, 0.2, 40.0}};
  DihedralTerm term(s);
  for (double bend_degrees : {1.0, 0.3, 0.01}) {
    const double bend = bend_degrees * M_PI / 180;  // k's angle is 180° − bend
    Coords q(3, 4);
    q.col(0) = Vec3(0.1, 0.05, 0.0);
    q.col(1) = Vec3(0, 0, 0);
    q.col(2) = Vec3(0, 0, 0.15);
    q.col(3) = Vec3(0.15 * std::sin(bend) * std::cos(0.7), 0.15 * std::sin(bend) * std::sin(0.7),
                    0.15 + 0.15 * std::cos(bend));
    expect_derivatives_match(term, q, "j-k-l at 180 - " + std::to_string(bend_degrees) + " degrees",
                             1e-3 * 0.15 * std::sin(bend));
  }
  Coords straight(3, 4);
  straight.col(0) = Vec3(0.1, 0.05, 0.0);
  straight.col(1) = Vec3(0, 0, 0);
  straight.col(2) = Vec3(0, 0, 0.15);
  straight.col(3) = Vec3(0, 0, 0.3);
  const auto at_straight = evaluate(term, straight);
  EXPECT_EQ(at_straight.f.cwiseAbs().maxCoeff(), 0.0);
  double expected = 5.0 * (1 + std::cos(-0.3)) + 0.5 * 40.0 * 0.2 * 0.2;
  for (int n = 0; n < 6; ++n) expected += s.rb_dihedrals[0].c[n] * std::pow(-1.0, n);  // cos ψ = −cos 0
  EXPECT_NEAR(at_straight.energy, expected, 1e-12);
  EXPECT_EQ(hessian_vector(term, straight, random_direction(4, 3)).cwiseAbs().maxCoeff(), 0.0);
}

}  // namespace
}  // namespace vimd
