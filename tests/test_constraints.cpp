// Constraint algebra (G, Gᵀ, H against finite differences and each other), the clustered
// factorisations against a dense solve, and the position / velocity constraint solvers on rigid
// water and on whole (linear and branched) chains, all in a periodic box with wrapped atoms.
#include <gtest/gtest.h>
#include <omp.h>

#include <random>

#include "engine/constraints.hpp"
#include "engine/errors.hpp"
#include "simd/settle_kernels.hpp"
#include "forcefields/nonbonded/nonbonded_kernels.hpp"
#include "tests/constrained_systems.hpp"
#include "simd/targets.hpp"

namespace vimd {
namespace {

using testing::add_chain;
using testing::add_water;

// Every cluster kind in one system: rigid waters (3 constraints), a diatomic and a triatomic
// (1 and 2), a 5- and a 10-bead chain (dense), a 200-bead chain and a branched 160-bead molecule
// (sparse). Chains are longer than the box, so many bonds cross its faces.
struct Zoo {
  System system;
  Coords q;
  Eigen::VectorXd inverse_mass;
  Constraints constraints;
};

Zoo make_zoo(int waters = 40) {
  const std::uint64_t seed = 7;
  Zoo z;
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> uniform(0.0, 3.0);
  z.system.box.length = Vec3::Constant(3.0);
  std::vector<Bond> springs;
  for (int k = 0; k < waters; ++k) add_water(z.system, z.q, Vec3(uniform(rng), uniform(rng), uniform(rng)), rng);
  add_chain(z.system, z.q, 2, 0, 0, 0.12, Vec3(0.5, 0.5, 0.5), rng, springs);
  add_chain(z.system, z.q, 3, 0, 0, 0.13, Vec3(1.5, 0.5, 0.5), rng, springs);
  add_chain(z.system, z.q, 5, 0, 0, 0.15, Vec3(0.5, 1.5, 0.5), rng, springs);
  add_chain(z.system, z.q, 10, 0, 0, 0.15, Vec3(0.5, 0.5, 1.5), rng, springs);
  add_chain(z.system, z.q, 200, 0, 0, 0.15, Vec3(1.5, 1.5, 1.5), rng, springs);
  add_chain(z.system, z.q, 100, 8, 5, 0.14, Vec3(2.5, 2.5, 2.5), rng, springs);
  testing::wrap(z.system.box, z.q);
  z.inverse_mass = z.system.mass.cwiseInverse();
  z.constraints = Constraints(z.system.constraints, z.system.n_atoms(), z.system.box);
  return z;
}

Coords random_coords(int n, double scale, std::mt19937_64& rng) {
  std::normal_distribution<double> normal;
  Coords x(3, n);
  for (int i = 0; i < n; ++i)
    for (int k = 0; k < 3; ++k) x(k, i) = scale * normal(rng);
  return x;
}

Eigen::VectorXd random_vector(int n, std::mt19937_64& rng) {
  std::normal_distribution<double> normal;
  Eigen::VectorXd x(n);
  for (int i = 0; i < n; ++i) x[i] = normal(rng);
  return x;
}

double dot(const Coords& a, const Coords& b) { return (a.array() * b.array()).sum(); }

// G(q) as a dense d × 3N matrix, straight from the definition (row a: r_a at i, −r_a at j).
Eigen::MatrixXd dense_G(const System& s, const Coords& q) {
  Eigen::MatrixXd G = Eigen::MatrixXd::Zero(s.constraints.size(), 3 * s.n_atoms());
  for (std::size_t a = 0; a < s.constraints.size(); ++a) {
    const Constraint& c = s.constraints[a];
    const Vec3 r = s.box.minimum_image(q.col(c.i) - q.col(c.j));
    G.block<1, 3>(a, 3 * c.i) = r.transpose();
    G.block<1, 3>(a, 3 * c.j) = -r.transpose();
  }
  return G;
}

Eigen::VectorXd flat(const Coords& x) { return Eigen::Map<const Eigen::VectorXd>(x.data(), x.size()); }

TEST(Constraints, ClustersAreTheConnectedComponents) {
  Zoo z = make_zoo();
  const auto& clusters = z.constraints.clusters();
  // Every molecule is connected and no two share atoms: one cluster per molecule.
  EXPECT_EQ(static_cast<int>(clusters.size()), z.system.molecule.back() + 1);
  std::vector<int> cluster_of_atom(z.system.n_atoms(), -1);
  int covered = 0;
  for (std::size_t c = 0; c < clusters.size(); ++c)
    for (int a : clusters[c]) {
      ++covered;
      for (int atom : {z.system.constraints[a].i, z.system.constraints[a].j}) {
        EXPECT_TRUE(cluster_of_atom[atom] < 0 || cluster_of_atom[atom] == static_cast<int>(c));
        cluster_of_atom[atom] = static_cast<int>(c);
      }
    }
  EXPECT_EQ(covered, z.constraints.size());
  std::vector<std::size_t> sizes;
  for (const auto& c : clusters) sizes.push_back(c.size());
  EXPECT_EQ(std::count(sizes.begin(), sizes.end(), 3u), 40);  // the waters
  EXPECT_EQ(std::count(sizes.begin(), sizes.end(), 199u), 1);
}

TEST(Constraints, BondVectorsUseTheMinimumImage) {
  Zoo z = make_zoo();
  // The generated geometry satisfies the constraints exactly, although atoms were wrapped.
  EXPECT_LT(z.constraints.max_relative_deviation(z.q), 1e-13);
  Eigen::VectorXd g;
  z.constraints.residuals(z.q, g);
  EXPECT_LT(g.cwiseAbs().maxCoeff(), 1e-15);
  Coords r;
  z.constraints.vectors(z.q, r);
  for (int a = 0; a < z.constraints.size(); ++a) EXPECT_NEAR(r.col(a).norm(), z.system.constraints[a].length, 1e-14);
}

TEST(Constraints, ApplyGIsTheDerivativeOfG) {
  Zoo z = make_zoo();
  std::mt19937_64 rng(1);
  const Coords u = random_coords(z.system.n_atoms(), 1.0, rng);
  Eigen::VectorXd gu, g_plus, g_minus;
  z.constraints.apply_G(z.q, u, gu);
  const double eps = 1e-6;
  z.constraints.residuals(z.q + eps * u, g_plus);
  z.constraints.residuals(z.q - eps * u, g_minus);
  const Eigen::VectorXd fd = (g_plus - g_minus) / (2 * eps);
  EXPECT_LT((fd - gu).cwiseAbs().maxCoeff(), 1e-8 * gu.cwiseAbs().maxCoeff());
}

TEST(Constraints, AddGTIsTheTransposeOfApplyG) {
  Zoo z = make_zoo();
  std::mt19937_64 rng(2);
  const Coords u = random_coords(z.system.n_atoms(), 1.0, rng);
  const Eigen::VectorXd lambda = random_vector(z.constraints.size(), rng);
  Eigen::VectorXd gu;
  z.constraints.apply_G(z.q, u, gu);
  Coords gt = Coords::Zero(3, z.system.n_atoms());
  z.constraints.add_GT(z.q, lambda, gt);
  EXPECT_NEAR(lambda.dot(gu), dot(u, gt), 1e-12 * std::abs(lambda.dot(gu)));

  // With weights: u·(W Gᵀλ) = λ·G(W u).
  Coords wu = u * z.inverse_mass.asDiagonal();
  z.constraints.apply_G(z.q, wu, gu);
  Coords wgt = Coords::Zero(3, z.system.n_atoms());
  z.constraints.add_GT(z.q, lambda, wgt, z.inverse_mass);
  EXPECT_NEAR(lambda.dot(gu), dot(u, wgt), 1e-12 * std::abs(lambda.dot(gu)));

  // And against the dense matrix; add_GT adds to what is there.
  Coords twice = gt;
  z.constraints.add_GT(z.q, lambda, twice);
  const Eigen::VectorXd dense = dense_G(z.system, z.q).transpose() * lambda;
  EXPECT_LT((flat(twice) - 2 * dense).cwiseAbs().maxCoeff(), 1e-13 * dense.cwiseAbs().maxCoeff());
}

TEST(Constraints, AddHIsTheDerivativeOfG) {
  Zoo z = make_zoo();
  std::mt19937_64 rng(3);
  const int n = z.system.n_atoms();
  const Coords u = random_coords(n, 1.0, rng), y = random_coords(n, 1.0, rng);
  const Eigen::VectorXd c = random_vector(z.constraints.size(), rng);
  // d/dε c·G(q + εy)x = x·Σ c_a H_a y; with weights, add_H gives W Σ c_a H_a y, so x = W u.
  auto derivative = [&](const Coords& x) {
    const double eps = 1e-5;
    Eigen::VectorXd plus, minus;
    z.constraints.apply_G(z.q + eps * y, x, plus);
    z.constraints.apply_G(z.q - eps * y, x, minus);
    return c.dot(plus - minus) / (2 * eps);
  };
  Coords hy = Coords::Zero(3, n), why = Coords::Zero(3, n);
  z.constraints.add_H(c, y, hy);
  z.constraints.add_H(c, y, why, z.inverse_mass);
  const double plain = derivative(u), weighted = derivative(u * z.inverse_mass.asDiagonal());
  EXPECT_NEAR(dot(u, hy), plain, 1e-8 * std::abs(plain));
  EXPECT_NEAR(dot(u, why), weighted, 1e-8 * std::abs(weighted));
}

// S = G(q_left) W G(q_right)ᵀ solved per cluster against a dense LU of the whole matrix.
TEST(Constraints, FactorizationMatchesDenseSolve) {
  Zoo z = make_zoo();
  std::mt19937_64 rng(4);
  const Coords q_other = z.q + random_coords(z.system.n_atoms(), 0.01, rng);
  Constraints::Factorization factorization;
  struct Case {
    const Coords* left;
    const Coords* right;
    bool weighted;
  };
  for (const Case& k : {Case{&z.q, &z.q, true}, Case{&q_other, &z.q, true}, Case{&z.q, &q_other, false},
                        Case{&q_other, &q_other, false}}) {
    const Eigen::VectorXd w = k.weighted ? z.inverse_mass : Eigen::VectorXd::Ones(z.system.n_atoms());
    z.constraints.factorize(*k.left, *k.right, k.weighted ? z.inverse_mass : Eigen::VectorXd(), factorization);
    Eigen::VectorXd w3(3 * w.size());
    for (int i = 0; i < w.size(); ++i) w3.segment<3>(3 * i).setConstant(w[i]);
    const Eigen::MatrixXd S = dense_G(z.system, *k.left) * w3.asDiagonal() * dense_G(z.system, *k.right).transpose();
    const Eigen::VectorXd rhs = random_vector(z.constraints.size(), rng);
    const Eigen::VectorXd expected = S.partialPivLu().solve(rhs);
    Eigen::VectorXd x = rhs;
    factorization.solve(x);
    EXPECT_LT((x - expected).cwiseAbs().maxCoeff(), 1e-10 * expected.cwiseAbs().maxCoeff())
        << "symmetric " << (k.left == k.right) << " weighted " << k.weighted;
    EXPECT_LT((S * x - rhs).cwiseAbs().maxCoeff(), 1e-11 * rhs.cwiseAbs().maxCoeff());
  }
}

TEST(Constraints, SolveBeforeFactorizeIsAnError) {
  Constraints::Factorization factorization;
  Eigen::VectorXd x = Eigen::VectorXd::Ones(3);
  EXPECT_THROW(factorization.solve(x), std::logic_error);
}

// The position stage on every kind of cluster at once, including whole chains.
TEST(Constraints, SolvePositionsReachesToleranceAlongGrefT) {
  Zoo z = make_zoo();
  std::mt19937_64 rng(5);
  for (double scale : {0.001, 0.01}) {  // per coordinate; 0.01 nm bends water bonds by ~15 %
    const Coords start = z.q + random_coords(z.system.n_atoms(), scale, rng);
    Coords q = start;
    Eigen::VectorXd lambda;
    double reported = -1;
    const int iterations = z.constraints.solve_positions(z.q, q, z.inverse_mass, 1e-10, 0, 500, &lambda, &reported);
    EXPECT_LE(z.constraints.max_relative_deviation(q), 1e-10);
    EXPECT_NEAR(reported, z.constraints.max_relative_deviation(q), 1e-14);
    EXPECT_GT(iterations, 0);
    EXPECT_LE(iterations, 20) << "scale " << scale;
    // q moved exactly along M⁻¹ G(q_ref)ᵀ λ.
    Coords rebuilt = start;
    z.constraints.add_GT(z.q, lambda, rebuilt, z.inverse_mass);
    EXPECT_LT((rebuilt - q).cwiseAbs().maxCoeff(), 1e-13);
  }
}

// Large corrections (σ = 0.018 nm per coordinate) on one branched 295-constraint cluster: for
// these 8 solves the chord iteration with S(q_ref) alone takes 160 iterations in total;
// switching to the exact Newton matrix when it stalls takes 66.
TEST(Constraints, LargeChainCorrectionsSwitchToExactNewton) {
  System s;
  Coords q;
  std::mt19937_64 rng(3);
  std::vector<Bond> springs;
  add_chain(s, q, 200, 8, 4, 0.15, Vec3(0, 0, 0), rng, springs);
  const Constraints constraints(s.constraints, s.n_atoms(), s.box);
  ASSERT_EQ(constraints.clusters().size(), 1u);
  const Eigen::VectorXd w = s.mass.cwiseInverse();
  int total = 0;
  for (int trial = 0; trial < 8; ++trial) {
    Coords moved = q + random_coords(s.n_atoms(), 0.018, rng);
    total += constraints.solve_positions(q, moved, w, 1e-10, 0, 100);
    EXPECT_LE(constraints.max_relative_deviation(moved), 1e-10);
  }
  EXPECT_LE(total, 110);
}

// Two full SETTLE batches and a partial one: waters at random places in a 2 nm box, atoms wrapped.
void scattered_waters(System& s, Coords& q, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> uniform(0.0, 2.0);
  s.box.length = Vec3::Constant(2.0);
  for (int k = 0; k < 2 * kSettleBatch + 22; ++k) add_water(s, q, Vec3(uniform(rng), uniform(rng), uniform(rng)), rng);
  testing::wrap(s.box, q);
}

// Rigid waters are solved by SETTLE unless multipliers are asked for (then by Newton): both solve
// the same equations, so they must agree to round-off, for waters split by the box faces too (all
// atoms wrapped). SETTLE does it in one pass; with unequal hydrogen weights it does not apply and
// Newton runs.
void expect_settle_matches_newton() {
  System s;
  Coords q;
  std::mt19937_64 rng(11);
  scattered_waters(s, q, rng);
  const Constraints constraints(s.constraints, s.n_atoms(), s.box);
  Eigen::VectorXd w = s.mass.cwiseInverse();
  for (const bool equal_hydrogens : {true, false}) {
    if (!equal_hydrogens) w[2] *= 1.5;  // the first water's second hydrogen
    for (double scale : {0.001, 0.01}) {
      const Coords start = q + random_coords(s.n_atoms(), scale, rng);
      Coords settled = start, newton = start;
      Eigen::VectorXd lambda;
      const int passes = constraints.solve_positions(q, settled, w, 1e-13, 0, 100);
      const int iterations = constraints.solve_positions(q, newton, w, 1e-13, 0, 100, &lambda);
      EXPECT_LE(constraints.max_relative_deviation(settled), 1e-13);
      EXPECT_LT((settled - newton).cwiseAbs().maxCoeff(), 1e-13) << "scale " << scale;
      EXPECT_GT(iterations, 1);
      // The most iterations any cluster took: 1 if every water was settled.
      EXPECT_EQ(passes == 1, equal_hydrogens) << "scale " << scale << ", " << passes << " iterations";
    }
  }
}

// SETTLE runs in batches of kSettleBatch molecules (here two full and a partial one) through the
// SIMD kernel: on every target.
TEST(Constraints, SettleMatchesNewtonOnRigidWater) {
  for (const std::string& target : simd::available_targets()) {
    SCOPED_TRACE(target);
    simd::use_target(target);
    expect_settle_matches_newton();
  }
  simd::use_target("");
}

// Batches of waters stored apex, h1, h2 in turn move their positions in whole vectors; stored in
// another order, one molecule at a time. Both give the same bits, positions and step velocities,
// also in a batch with one water left to Newton (unequal hydrogens): on every target.
TEST(Constraints, SettleGivesTheSameBitsWhateverTheAtomOrder) {
  System s;
  Coords q;
  std::mt19937_64 rng(17);
  scattered_waters(s, q, rng);
  const int n = s.n_atoms();
  // Each molecule's atoms stored h1, h2, apex instead: no batch is consecutive any more.
  std::vector<int> moved_to(n);
  for (int a = 0; a < n; ++a) moved_to[a] = a % 3 == 0 ? a + 2 : a - 1;
  std::vector<Constraint> permuted = s.constraints;
  for (Constraint& c : permuted) c.i = moved_to[c.i], c.j = moved_to[c.j];
  const Constraints in_order(s.constraints, n, s.box), reordered(permuted, n, s.box);
  auto permute = [&](const auto& x) {
    std::remove_cvref_t<decltype(x)> y = x;
    for (int a = 0; a < n; ++a) y.col(moved_to[a]) = x.col(a);
    return y;
  };
  Eigen::VectorXd w = s.mass.cwiseInverse();
  w[3 * kSettleBatch + 1] *= 1.5;  // the second batch's first water
  const Eigen::VectorXd w_permuted = permute(Eigen::RowVectorXd(w.transpose())).transpose();
  const double h = 0.002;
  for (const std::string& target : simd::available_targets()) {
    SCOPED_TRACE(target);
    simd::use_target(target);
    const Coords start = q + random_coords(n, 0.01, rng), v_start = random_coords(n, 1.0, rng);
    Coords q_a = start, v_a = v_start, q_b = permute(start), v_b = permute(v_start);
    const StepVelocity step_a{v_a, h}, step_b{v_b, h};
    in_order.solve_positions(q, q_a, w, 1e-12, 0, 100, nullptr, nullptr, &step_a);
    reordered.solve_positions(permute(q), q_b, w_permuted, 1e-12, 0, 100, nullptr, nullptr, &step_b);
    EXPECT_LE(in_order.max_relative_deviation(q_a), 1e-12);
    EXPECT_EQ(permute(q_a), q_b);
    EXPECT_EQ(permute(v_a), v_b);
  }
  simd::use_target("");
}

// A position stage asked for the step velocity leaves v_i = (q_i − q_ref,i)/h on every constrained
// atom (SETTLE's waters, Newton's chains, and a water SETTLE hands to Newton) and v untouched elsewhere.
TEST(Constraints, StepVelocityIsTheConstrainedDisplacementOverTheStep) {
  Zoo z = make_zoo();
  std::mt19937_64 rng(5);
  const int n = z.system.n_atoms() + 2;  // two free atoms at the end
  Coords q_ref(3, n);
  q_ref << z.q, Coords::Constant(3, 2, 1.0);
  Eigen::VectorXd w(n);
  w << z.inverse_mass, 0.1, 0.1;
  w[2] *= 1.5;  // the first water's hydrogens unequal: Newton's
  const Constraints constraints(z.system.constraints, n, z.system.box);
  std::vector<char> constrained(n, 0);
  for (const Constraint& c : z.system.constraints) constrained[c.i] = constrained[c.j] = 1;
  const double h = 0.002;
  const Coords v_start = random_coords(n, 1.0, rng);
  Coords v = v_start, q = q_ref + h * v_start;
  const StepVelocity half_step{v, h};
  constraints.solve_positions(q_ref, q, w, 1e-12, 0, 100, nullptr, nullptr, &half_step);
  EXPECT_LE(constraints.max_relative_deviation(q), 1e-12);
  for (int i = 0; i < n; ++i) {
    if (constrained[i])
      EXPECT_EQ(v.col(i), Vec3((q.col(i) - q_ref.col(i)) * (1 / h))) << "atom " << i;
    else
      EXPECT_EQ(v.col(i), v_start.col(i)) << "atom " << i;
  }
}

TEST(Constraints, SolvePositionsOnSatisfiedConstraintsDoesNothing) {
  Zoo z = make_zoo();
  Coords q = z.q;
  EXPECT_EQ(z.constraints.solve_positions(z.q, q, z.inverse_mass, 1e-10, 0), 0);
  EXPECT_EQ((q - z.q).cwiseAbs().maxCoeff(), 0.0);
}

// Rigid waters go through the SIMD projection kernel in batches of kSettleBatch (here two full and a
// partial one), the chains through the general path: on every target.
TEST(Constraints, ProjectVelocitiesIsTheMassOrthogonalProjection) {
  Zoo z = make_zoo(150);
  for (const std::string& target : simd::available_targets()) {
    SCOPED_TRACE(target);
    simd::use_target(target);
    std::mt19937_64 rng(6);
    const Coords v0 = random_coords(z.system.n_atoms(), 1.0, rng);
    Coords v = v0;
    Eigen::VectorXd mu;
    EXPECT_GT(z.constraints.max_velocity_residual(z.q, v), 1e-2);
    z.constraints.project_velocities(z.q, v, z.inverse_mass, &mu);
    EXPECT_LT(z.constraints.max_velocity_residual(z.q, v), 1e-13);
    // v = v0 − M⁻¹ Gᵀ μ
    Coords rebuilt = v0;
    z.constraints.add_GT(z.q, -mu, rebuilt, z.inverse_mass);
    EXPECT_LT((rebuilt - v).cwiseAbs().maxCoeff(), 1e-13);
    // Pythagoras in the kinetic-energy metric: the removed part is M-orthogonal to the rest.
    auto kinetic = [&](const Coords& x) {
      return (x.colwise().squaredNorm().transpose().array() * z.system.mass.array()).sum();
    };
    EXPECT_NEAR(kinetic(v0), kinetic(v) + kinetic(v0 - v), 1e-12 * kinetic(v0));
    // A projection: applying it again changes nothing.
    Coords again = v;
    z.constraints.project_velocities(z.q, again, z.inverse_mass);
    EXPECT_LT((again - v).cwiseAbs().maxCoeff(), 1e-14);
  }
  simd::use_target("");
}

TEST(Constraints, OneAndTwoThreadsGiveIdenticalResults) {
  Zoo z = make_zoo(300);
  ASSERT_GT(z.constraints.size(), 1000);  // large enough for the parallel paths
  std::mt19937_64 rng(8);
  const Coords start = z.q + random_coords(z.system.n_atoms(), 0.01, rng);
  const Coords v0 = random_coords(z.system.n_atoms(), 1.0, rng);
  Coords q[2], v[2];
  const int threads = omp_get_max_threads();
  for (int t : {1, 2}) {
    omp_set_num_threads(t);
    q[t - 1] = start;
    z.constraints.solve_positions(z.q, q[t - 1], z.inverse_mass, 1e-10, 0);
    v[t - 1] = v0;
    z.constraints.project_velocities(q[t - 1], v[t - 1], z.inverse_mass);
  }
  omp_set_num_threads(threads);
  EXPECT_EQ((q[0] - q[1]).cwiseAbs().maxCoeff(), 0.0);
  EXPECT_EQ((v[0] - v[1]).cwiseAbs().maxCoeff(), 0.0);
}

TEST(Constraints, NonConvergenceNamesStepWorstConstraintAndIterations) {
  Zoo z = make_zoo();
  std::mt19937_64 rng(9);
  Coords q = z.q + random_coords(z.system.n_atoms(), 0.01, rng);
  try {
    z.constraints.solve_positions(z.q, q, z.inverse_mass, 1e-10, 42, 1);
    FAIL() << "expected ConvergenceError";
  } catch (const ConvergenceError& e) {
    EXPECT_EQ(e.step(), 42);
    EXPECT_EQ(e.iterations(), 1);
    EXPECT_GT(e.residual(), 1e-10);
    const std::string what = e.what();
    EXPECT_NE(what.find("step 42"), std::string::npos) << what;
    EXPECT_NE(what.find("after 1 iterations"), std::string::npos) << what;
    EXPECT_NE(what.find("atoms "), std::string::npos) << what;
    EXPECT_NE(what.find("tolerance"), std::string::npos) << what;
  }
}

TEST(Constraints, NoSolutionOnTheConstraintLineIsAConvergenceError) {
  // Moving along G(q_ref)ᵀ (the x axis) can never shorten the 0.5 nm y-offset to 0.1 nm.
  Coords q_ref(3, 2), q(3, 2);
  q_ref << 0, 0.1, 0, 0, 0, 0;
  q << 0, 0.1, 0, 0.5, 0, 0;
  Constraints constraints({{0, 1, 0.1}}, 2, Box{});
  try {
    constraints.solve_positions(q_ref, q, Eigen::VectorXd::Ones(2), 1e-10, 3, 100);
    FAIL() << "expected ConvergenceError";
  } catch (const ConvergenceError& e) {
    EXPECT_EQ(e.step(), 3);
    EXPECT_NE(std::string(e.what()).find("constraint 1 (atoms 1-2"), std::string::npos) << e.what();
  }
}

TEST(Constraints, InvalidListsAreInputErrors) {
  EXPECT_THROW(Constraints({{0, 0, 0.1}}, 2, Box{}), InputError);
  EXPECT_THROW(Constraints({{0, 2, 0.1}}, 2, Box{}), InputError);
  EXPECT_THROW(Constraints({{0, 1, 0.0}}, 2, Box{}), InputError);
  EXPECT_THROW(Constraints({{0, 1, 0.1}, {1, 0, 0.1}}, 2, Box{}), InputError);
}

TEST(Constraints, EmptySetIsHarmless) {
  Constraints none({}, 3, Box{});
  Coords q = Coords::Random(3, 3), v = Coords::Random(3, 3);
  const Coords q0 = q, v0 = v;
  EXPECT_EQ(none.solve_positions(q0, q, Eigen::VectorXd::Ones(3), 1e-10, 0), 0);
  none.project_velocities(q, v, Eigen::VectorXd::Ones(3));
  EXPECT_EQ(q, q0);
  EXPECT_EQ(v, v0);
  EXPECT_EQ(none.max_relative_deviation(q), 0.0);
  Constraints::Factorization f;
  none.factorize(q, q, Eigen::VectorXd(), f);
  Eigen::VectorXd empty;
  f.solve(empty);
}

TEST(Constraints, FactorizationOutlivesAMovedFrom) {
  Zoo z = make_zoo();
  Constraints::Factorization f;
  z.constraints.factorize(z.q, z.q, z.inverse_mass, f);
  Eigen::VectorXd x = Eigen::VectorXd::Ones(z.constraints.size());
  Constraints moved = std::move(z.constraints);
  f.solve(x);
  Eigen::VectorXd check;
  Coords gt = Coords::Zero(3, z.system.n_atoms());
  moved.add_GT(z.q, x, gt, z.inverse_mass);
  moved.apply_G(z.q, gt, check);  // S x = G W Gᵀ x
  EXPECT_LT((check - Eigen::VectorXd::Ones(moved.size())).cwiseAbs().maxCoeff(), 1e-11);
}

}  // namespace
}  // namespace vimd
