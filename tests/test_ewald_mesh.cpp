// The Ewald mesh (reciprocal part of smooth PME): B-splines, energy and forces against a plain
// Ewald k-space sum, derivatives against finite differences, invariances, net charge, precision
// and threads.
#include <gtest/gtest.h>
#include <omp.h>

#include <algorithm>
#include <cmath>
#include <complex>
#include <random>
#include <string>
#include <type_traits>
#include <vector>

#include "app/run_schema.hpp"
#include "derivative_checks.hpp"
#include "engine/errors.hpp"
#include "forcefields/bspline.hpp"
#include "forcefields/ewald_mesh.hpp"
#include "forcefields/ewald_mesh_kernels.hpp"
#include "forcefields/nonbonded/ewald.hpp"
#include "forcefields/nonbonded/nonbonded_kernels.hpp"
#include "forcefields/settings.hpp"
#include "test_ff_systems.hpp"
#include "simd/targets.hpp"

namespace vimd {
namespace {

using testing::evaluate;
using testing::expect_derivatives_match;
using testing::hessian_vector;
using testing::random_direction;
using testing::relative_difference;

constexpr double kBeta = 3.123413;  // GROMACS's β for r_c = 1 nm, ewald-rtol 1e-5

EwaldMeshParameters parameters(std::array<int, 3> grid, int order, double beta = kBeta) {
  return {grid, order, beta, kCoulomb};
}

// ---------------------------------------------------------------------------------------------
// B-splines

// M_p(x) from its definition as p-fold convolution of the unit box, by the explicit formula
// M_p(x) = 1/(p−1)! Σ_{j=0}^{p} (−1)^j C(p,j) max(x − j, 0)^{p−1}, in long double: the sum
// cancels (to 1e-12 in double at p = 12).
double cardinal_bspline(int p, double x) {
  long double sum = 0, binomial = 1, factorial = 1;
  for (int k = 2; k < p; ++k) factorial *= k;
  for (int j = 0; j <= p; ++j) {
    if (x > j) sum += (j % 2 ? -1 : 1) * binomial * std::pow(static_cast<long double>(x) - j, p - 1);
    binomial = binomial * (p - j) / (j + 1);
  }
  return static_cast<double>(sum / factorial);
}

TEST(BSpline, WeightsAreTheCardinalSplineAndItsDerivatives) {
  for (int p : {3, 4, 5, 8, 12})
    for (double d : {0.0, 0.13, 0.5, 0.77, 0.999}) {
      SplineWeights<double> w, plus, minus;
      spline_weights(d, p, true, w);
      const double h = 1e-6;
      spline_weights(d + h, p, true, plus);
      spline_weights(d - h, p, true, minus);
      double sum = 0, sum_first = 0, sum_second = 0;
      for (int k = 0; k < p; ++k) {
        EXPECT_NEAR(w.value[k], cardinal_bspline(p, d + p - 1 - k), 1e-13) << p << " " << d << " " << k;
        if (d > 0) {  // central differences need both sides inside the cell
          EXPECT_NEAR(w.first[k], (plus.value[k] - minus.value[k]) / (2 * h), 1e-8) << p << " " << d << " " << k;
          EXPECT_NEAR(w.second[k], (plus.first[k] - minus.first[k]) / (2 * h), 1e-7) << p << " " << d << " " << k;
        }
        sum += w.value[k];
        sum_first += w.first[k];
        sum_second += w.second[k];
      }
      EXPECT_NEAR(sum, 1, 1e-14);  // partition of unity, hence derivatives summing to zero
      EXPECT_NEAR(sum_first, 0, 1e-13);
      EXPECT_NEAR(sum_second, 0, 1e-12);
    }
}

TEST(BSpline, ValuesAtIntegers) {
  const auto m4 = spline_at_integers(4);
  EXPECT_NEAR(m4[0], 1.0 / 6, 1e-15);
  EXPECT_NEAR(m4[1], 4.0 / 6, 1e-15);
  EXPECT_NEAR(m4[2], 1.0 / 6, 1e-15);
  for (int p : {3, 6, 11})
    for (int j = 1; j < p; ++j) EXPECT_NEAR(spline_at_integers(p)[j - 1], cardinal_bspline(p, j), 1e-14);
}

// ---------------------------------------------------------------------------------------------
// Against a plain Ewald sum

// The reciprocal part of an Ewald sum by direct summation over k (tin-foil boundary):
//   E = f/(2πV) Σ_{0<|k|∞≤kmax} exp(−π²m²/β²)/m² |Σ_j q_j e^{2πi m·r_j}|², m = (k_x/L_x, …)
// plus the neutralising background's −π f Q²/(2Vβ²), and its forces.
struct EwaldReference {
  double energy = 0;
  Coords f;
};

EwaldReference ewald_reciprocal(const System& s, const Coords& q, double beta, int kmax) {
  const Vec3 L = s.box.length;
  const double volume = s.box.volume();
  const int n = s.n_atoms();
  EwaldReference r;
  r.f.setZero(3, n);
  std::vector<std::complex<double>> phase(n);
  for (int kx = -kmax; kx <= kmax; ++kx)
    for (int ky = -kmax; ky <= kmax; ++ky)
      for (int kz = -kmax; kz <= kmax; ++kz) {
        if (kx == 0 && ky == 0 && kz == 0) continue;
        const Vec3 m(kx / L[0], ky / L[1], kz / L[2]);
        const double m2 = m.squaredNorm();
        const double g = kCoulomb / (2 * M_PI * volume) * std::exp(-M_PI * M_PI * m2 / (beta * beta)) / m2;
        std::complex<double> sum = 0;
        for (int j = 0; j < n; ++j) {
          phase[j] = std::polar(1.0, 2 * M_PI * m.dot(q.col(j)));
          sum += s.charge[j] * phase[j];
        }
        r.energy += g * std::norm(sum);
        // ∂|S|²/∂r_j = 2 Re(conj(S) q_j 2πi m e^{2πi m·r_j})
        for (int j = 0; j < n; ++j)
          r.f.col(j) -= g * 2 * std::real(std::conj(sum) * s.charge[j] * std::complex<double>(0, 2 * M_PI) * phase[j]) * m;
      }
  const double total = s.charge.sum();
  r.energy -= M_PI * kCoulomb * total * total / (2 * volume * beta * beta);
  return r;
}

testing::TestSystem small_water() { return testing::water_like_system(5, Vec3(1.6, 1.5, 1.4), 11); }

TEST(EwaldMesh, ConvergesToThePlainEwaldSum) {
  const auto [system, q] = small_water();
  const auto ref = ewald_reciprocal(system, q, kBeta, 16);
  struct Case {
    std::array<int, 3> grid;
    int order;
    double energy_tolerance, force_tolerance;
  };
  // GROMACS's defaults (spacing ≤ 0.12 nm, order 4), then finer grids and higher orders.
  for (const Case& c : {Case{{14, 13, 12}, 4, 2e-3, 2e-2}, Case{{14, 13, 12}, 8, 1e-4, 1e-3},
                        Case{{32, 30, 28}, 5, 1e-5, 1e-4}, Case{{32, 30, 28}, 8, 1e-7, 1e-6},
                        Case{{48, 45, 42}, 12, 1e-9, 1e-8}}) {
    EwaldMeshTerm term(system, parameters(c.grid, c.order), false);
    const auto r = evaluate(term, q);
    const double e_error = std::abs(r.energy - ref.energy) / std::abs(ref.energy);
    const double f_error = relative_difference(r.f, ref.f);
    EXPECT_LT(e_error, c.energy_tolerance) << "order " << c.order << " grid " << c.grid[0];
    EXPECT_LT(f_error, c.force_tolerance) << "order " << c.order << " grid " << c.grid[0];
    std::printf("order %2d grid %2d: energy %.3e, forces %.3e relative error\n", c.order, c.grid[0], e_error, f_error);
  }
}

// GROMACS's estimate of the mesh's RMS force error (ewald_mesh_force_error, which `vimd check`
// prints and the input check compares with ewald_rtol's promise) against the error measured: the
// forces of the grid and order under test against a grid of order 12 at 0.04 nm, converged to 1e-9
// (ConvergesToThePlainEwaldSum), from 0.1 % to 100 % of the force, over grids, orders and beta.
// With the charges of a water-like system shuffled among its atoms (uncorrelated, as the estimate
// assumes) it is within a factor of 1.6 (0.9-1.0, 0.67 for an odd order on an even grid); on the
// water molecules themselves, whose charges partly cancel, it is high by up to 3.3 times and never
// below half the error: within a factor of 4.
TEST(EwaldMesh, ForceErrorEstimateTracksTheMeasuredError) {
  const Vec3 box(2.5, 2.4, 2.6);
  const auto [water, q] = testing::water_like_system(120, box, 5);
  System shuffled = water;
  struct Charges {
    const System* system;
    double low, high;  // the bounds of estimate / measured
  };
  std::shuffle(shuffled.charge.begin(), shuffled.charge.end(), std::mt19937_64(3));
  struct Case {
    std::array<int, 3> grid;
    int order;
    double beta;
  };
  const double beta_0_4 = 7.808533;  // erfc(β 0.4 nm) = 1e-5: coulomb_switch = 0.4 nm
  const Case cases[] = {{{21, 20, 22}, 4, kBeta},    {{16, 16, 16}, 4, kBeta},    {{12, 12, 12}, 4, kBeta},
                        {{21, 20, 22}, 5, kBeta},    {{21, 20, 22}, 6, kBeta},    {{21, 20, 22}, 4, beta_0_4},
                        {{32, 30, 32}, 4, beta_0_4}, {{32, 30, 32}, 5, beta_0_4}, {{32, 32, 32}, 6, beta_0_4}};
  for (const auto& [system, low, high] : {Charges{&shuffled, 1 / 1.6, 1.6}, Charges{&water, 0.25, 4.0}}) {
    double sum_q2 = 0, sum_q4 = 0;
    for (double x : system->charge) sum_q2 += x * x, sum_q4 += x * x * x * x;
    const int n = system->n_atoms();
    for (const Case& c : cases) {
      EwaldMeshTerm term(*system, parameters(c.grid, c.order, c.beta), false);
      EwaldMeshTerm reference(*system, parameters({64, 60, 64}, 12, c.beta), false);
      const Coords error = evaluate(term, q).f - evaluate(reference, q).f;
      const double measured = std::sqrt(error.colwise().squaredNorm().sum() / n);
      const double estimate =
          ewald_mesh_force_error(box, c.grid, c.order, c.beta, kCoulomb, sum_q2, sum_q4, n).total();
      std::printf("%s grid %2d order %d beta %.3g: RMS force error %.3e kJ/mol/nm, estimate %.3e (ratio %.2f)\n",
                  system == &water ? "water   " : "shuffled", c.grid[0], c.order, c.beta, measured, estimate,
                  estimate / measured);
      EXPECT_LT(estimate, high * measured) << "grid " << c.grid[0] << " order " << c.order << " beta " << c.beta;
      EXPECT_GT(estimate, low * measured) << "grid " << c.grid[0] << " order " << c.order << " beta " << c.beta;
    }
  }
}

// Beyond 64 grid points a direction the estimate is taken on a box of 64 at the same spacing:
// the sums there approximate the same integrals. Against the full sums of a box just below that.
TEST(EwaldMesh, ForceErrorEstimateOfALargeGridFromASmallerBox) {
  const double sum_q2 = 400, sum_q4 = 300;
  const int n_charges = 1000;
  for (int order : {4, 5, 8}) {
    const MeshForceError full = ewald_mesh_force_error(Vec3(7.2, 7.2, 6.0), {60, 60, 50}, order, kBeta, kCoulomb,
                                                       sum_q2, sum_q4, n_charges);
    const MeshForceError proxied = ewald_mesh_force_error(Vec3(14.4, 14.4, 6.0), {120, 120, 50}, order, kBeta,
                                                          kCoulomb, sum_q2, sum_q4, n_charges);
    // Terms I and II fall as 1/√V at the same charges; term III does not depend on V.
    EXPECT_NEAR(proxied.pairs * 2, full.pairs, 0.02 * full.pairs) << "order " << order;
    EXPECT_NEAR(proxied.self, full.self, 0.02 * full.self) << "order " << order;
  }
}

TEST(EwaldMesh, NetChargeTerm) {
  auto [system, q] = small_water();
  system.charge[1] = 0;  // one hydrogen uncharged: net charge −0.4238 e
  const double total = system.charge.sum();
  EwaldMeshTerm term(system, parameters({32, 30, 28}, 8), false);
  EXPECT_NEAR(term.net_charge_energy(), -M_PI * kCoulomb * total * total / (2 * system.box.volume() * kBeta * kBeta), 1e-12);
  const auto ref = ewald_reciprocal(system, q, kBeta, 16);
  EXPECT_NEAR(evaluate(term, q).energy, ref.energy, 1e-7 * std::abs(ref.energy));
}

TEST(EwaldMesh, RefusesNonPeriodicBoxes) {
  auto [system, q] = small_water();
  system.box.length[2] = 0;
  EXPECT_THROW(EwaldMeshTerm(system, parameters({16, 16, 16}, 4), false), std::invalid_argument);
}

// ---------------------------------------------------------------------------------------------
// Derivatives, invariances

// pme_order has one range: the run file takes exactly the orders the mesh is built for.
TEST(EwaldMesh, RunFileAndMeshAcceptTheSamePmeOrders) {
  const auto [system, q] = small_water();
  const std::filesystem::path run_file = std::filesystem::path(VIMD_SOURCE_DIR) / "tests/data/config/full.toml";
  for (int order = 1; order <= kMaxSplineOrder + 2; ++order) {
    SCOPED_TRACE("pme_order " + std::to_string(order));
    bool read = true, built = true;
    try {
      read_config(run_file, run_schema(), {{"pme_order", long{order}}});
    } catch (const InputError& e) {
      read = false;
      EXPECT_NE(std::string(e.what()).find("pme_order must be between " + std::to_string(kMinPmeOrder) + " and " +
                                           std::to_string(kMaxPmeOrder)),
                std::string::npos)
          << e.what();
    }
    try {
      EwaldMeshTerm(system, parameters({24, 24, 24}, order), false);
    } catch (const std::invalid_argument&) {
      built = false;
    }
    EXPECT_EQ(read, order >= kMinPmeOrder && order <= kMaxPmeOrder);
    EXPECT_EQ(built, read);
  }
}

// A grid from a tiny spacing or a huge box is refused before anything is allocated, with its size,
// the memory it needs and the setting it comes from (a bad_alloc or a vector length error before).
TEST(EwaldMesh, GridBeyondMemoryIsRefusedBeforeAllocation) {
  ForceFieldConfig config;
  config.coulomb = "pme";
  Box box;
  box.length = Vec3(6, 6, 6);
  config.fourier_spacing = 1e-6;
  try {
    pme_grid_size(config, box);
    ADD_FAILURE() << "no error";
  } catch (const SettingError& e) {
    EXPECT_EQ(e.key(), "fourier_spacing");
    const std::string what = e.what();
    EXPECT_NE(what.find("fourier_spacing = 1e-06 nm in a box of 6 x 6 x 6 nm asks for a PME grid of "
                        "6000000 x 6000000 x 6000000 points, which needs 9.5e+06 PB; at most 4096 points"),
              std::string::npos)
        << what;
  }
  config.fourier_spacing = 0.12;
  box.length = Vec3(1000, 1000, 1000);
  EXPECT_THROW(pme_grid_size(config, box), SettingError);
  // Within the points a direction may have, the machine's memory decides.
  config.fourier_n = {kMaxFourierPoints, kMaxFourierPoints, kMaxFourierPoints};
  try {
    pme_grid_size(config, box);
    ADD_FAILURE() << "no error";
  } catch (const SettingError& e) {
    EXPECT_EQ(e.key(), "fourier_nx");
    EXPECT_NE(std::string(e.what()).find("of memory; this machine has"), std::string::npos) << e.what();
  }
  // The estimate counts what the mesh allocates: at 96³ in double with one thread, the two grids'
  // real and complex parts, the spreading grid and the influence function.
  const double n = 96, row = 96 + spline_stride(4) - 1 + 1, half = 96 * 96 * 49.0;
  EXPECT_DOUBLE_EQ(ewald_mesh_bytes({n, n, n}, 4, false, 1),
                   8 * half + 2 * 8 * (n * n * row + 2 * half) + 8 * (n + 3) * n * row);
}

TEST(EwaldMesh, ForcesAndHessianVectorMatchFiniteDifferences) {
  const auto [system, q] = small_water();
  for (int order : {4, 8, 12}) {
    EwaldMeshTerm term(system, parameters({16, 15, 14}, order), false);
    expect_derivatives_match(term, q, "order " + std::to_string(order));
  }
}

TEST(EwaldMesh, TranslationInvariance) {
  const auto [system, q] = small_water();
  const std::array<int, 3> grid{14, 13, 12};
  const Vec3 cell(system.box.length[0] / grid[0], system.box.length[1] / grid[1], system.box.length[2] / grid[2]);
  for (int order : {4, 8}) {
    EwaldMeshTerm term(system, parameters(grid, order), false);
    const auto at_q = evaluate(term, q);
    auto shifted = [&](const Vec3& by) {
      Coords p = q;
      p.colwise() += by;
      return evaluate(term, p);
    };
    // By whole grid cells or whole boxes (positions unwrapped): the same grid sums.
    for (const Vec3& by : {Vec3(cell[0], 2 * cell[1], -3 * cell[2]), Vec3(system.box.length[0], -2 * system.box.length[1], 0)}) {
      const auto r = shifted(by);
      EXPECT_NEAR(r.energy, at_q.energy, 1e-12 * std::abs(at_q.energy));
      EXPECT_LT(relative_difference(r.f, at_q.f), 1e-11);
    }
    // By a fraction of a cell: the interpolation's error (each charge's interaction with its own
    // interpolated images depends on where it sits in its cell), which a higher order shrinks.
    const auto r = shifted(Vec3(0.31 * cell[0], 0.57 * cell[1], 0.83 * cell[2]));
    const double tolerance = order == 4 ? 1e-2 : 1e-4;
    EXPECT_LT(std::abs(r.energy - at_q.energy), tolerance * std::abs(at_q.energy)) << order;
    EXPECT_LT(relative_difference(r.f, at_q.f), 10 * tolerance) << order;
  }
}

// Smooth PME does not conserve momentum exactly: the net force is of the interpolation's error.
TEST(EwaldMesh, NetForceIsOfTheInterpolationError) {
  const auto [system, q] = small_water();
  struct Case {
    std::array<int, 3> grid;
    int order;
    double tolerance;
  };
  for (const Case& c : {Case{{14, 13, 12}, 4, 1e-2}, Case{{32, 30, 28}, 8, 1e-6}}) {
    EwaldMeshTerm term(system, parameters(c.grid, c.order), false);
    const auto r = evaluate(term, q);
    const double net = r.f.rowwise().sum().norm(), scale = r.f.norm();
    EXPECT_LT(net, c.tolerance * scale) << c.order;
    std::printf("order %2d grid %2d: |net force| / |forces| = %.3e\n", c.order, c.grid[0], net / scale);
  }
}

// ---------------------------------------------------------------------------------------------
// Precision, threads, observations

TEST(EwaldMesh, SinglePrecisionAgreesToFloatRounding) {
  const auto [system, q] = small_water();
  const Coords u = random_direction(system.n_atoms(), 3);
  for (int order : {4, 8}) {
    EwaldMeshTerm exact(system, parameters({16, 15, 14}, order), false);
    EwaldMeshTerm mixed(system, parameters({16, 15, 14}, order), true);
    const auto d = evaluate(exact, q);
    const auto m = evaluate(mixed, q);
    const auto s = evaluate(exact, q, {.single_precision = true});
    EXPECT_NE(m.energy, d.energy);  // really float
    EXPECT_NEAR(m.energy, d.energy, 1e-5 * std::abs(d.energy));
    EXPECT_LT(relative_difference(m.f, d.f), 1e-5);
    EXPECT_EQ(s.energy, m.energy);
    EXPECT_EQ(s.f, m.f);
    const Coords hd = hessian_vector(exact, q, u), hm = hessian_vector(mixed, q, u);
    EXPECT_LT(relative_difference(hm, hd), 1e-4);
  }
}

TEST(EwaldMesh, ReproducibleAndThreadCountOnlyChangesRoundoff) {
  // Large enough for the mesh to start threads.
  const auto [system, q] = testing::water_like_system(100, Vec3(2.2, 2.3, 2.4), 5);
  const Coords u = random_direction(system.n_atoms(), 9);
  const int threads = omp_get_max_threads();
  EwaldMeshTerm term(system, parameters({20, 21, 22}, 8), false);
  const auto first = evaluate(term, q);
  const Coords first_hu = hessian_vector(term, q, u);
  const Coords q2 = q.array() + 0.01;
  evaluate(term, q2);  // elsewhere in between: the potential grid is not reused
  EXPECT_EQ(hessian_vector(term, q, u), first_hu);
  const auto again = evaluate(term, q);
  EXPECT_EQ(again.energy, first.energy);
  EXPECT_EQ(again.f, first.f);
  EXPECT_EQ(hessian_vector(term, q, u), first_hu);  // after a force pass at q: the potential grid reused

  // A single point is what a fresh term computes, and changes nothing.
  Coords f = Coords::Zero(3, q.cols());
  double e = 0;
  term.add_single_point(q2, f, std::span<double>(&e, 1));
  EwaldMeshTerm fresh(system, parameters({20, 21, 22}, 8), false);
  const auto at_q2 = evaluate(fresh, q2);
  EXPECT_EQ(e, at_q2.energy);
  EXPECT_EQ(f, at_q2.f);
  EXPECT_EQ(hessian_vector(term, q, u), first_hu);

  // Each thread spreads the atoms of its x planes onto them and the p − 1 after: 7 threads have
  // slabs narrower than those p − 1 planes, 23 more threads than the 20 planes.
  for (int t : {1, 2, 3, 7, 23}) {
    omp_set_num_threads(t);
    const auto r = evaluate(term, q);
    EXPECT_NEAR(r.energy, first.energy, 1e-13 * std::abs(first.energy)) << t;
    EXPECT_LT(relative_difference(r.f, first.f), 1e-13) << t;
    EXPECT_LT(relative_difference(hessian_vector(term, q, u), first_hu), 1e-13) << t;
  }

  // Called inside a parallel region, without nested parallelism: the mesh asks for 3 threads and
  // gets 1, which it must compute with as one thread does.
  omp_set_num_threads(1);
  const auto one_thread = evaluate(term, q);
  omp_set_num_threads(3);
  const int levels = omp_get_max_active_levels();
  omp_set_max_active_levels(1);
  testing::TermResult nested;
#pragma omp parallel num_threads(2)
  {
#pragma omp single
    nested = evaluate(term, q);
  }
  omp_set_max_active_levels(levels);
  EXPECT_EQ(nested.energy, one_thread.energy);
  EXPECT_EQ(nested.f, one_thread.f);
  omp_set_num_threads(threads);
}

TEST(EwaldMesh, SimdTargetsAgree) {
  const auto [system, q] = small_water();
  const Coords u = random_direction(system.n_atoms(), 2);
  for (int order : {4, 5, 12}) {
    std::vector<testing::TermResult> results;
    std::vector<Coords> products;
    for (const std::string& target : simd::available_targets()) {
      simd::use_target(target);
      EwaldMeshTerm term(system, parameters({16, 15, 14}, order), false);
      results.push_back(evaluate(term, q));
      products.push_back(hessian_vector(term, q, u));
      EXPECT_NEAR(results.back().energy, results[0].energy, 1e-13 * std::abs(results[0].energy)) << target << " " << order;
      EXPECT_LT(relative_difference(results.back().f, results[0].f), 1e-13) << target << " " << order;
      EXPECT_LT(relative_difference(products.back(), products[0]), 1e-13) << target << " " << order;
    }
    simd::use_target("");
  }
}

// The kernels' cells and weights, computed on vectors of atoms where the order allows, against
// spline_weights atom by atom: every target, both precisions, a count that leaves a tail, atoms
// outside the box and on its faces.
template <class Real>
void expect_kernel_splines_match(const MeshKernels<Real>& kernels, int p, const std::string& what) {
  constexpr int n_atoms = 37;
  const std::array<int, 3> n{16, 15, 14};
  const std::array<double, 3> length{1.6, 1.5, 1.4};
  Coords q(3, n_atoms);
  std::mt19937 random(5);
  std::uniform_real_distribution<double> fraction(-1.3, 2.2);
  for (int i = 0; i < n_atoms; ++i)
    for (int d = 0; d < 3; ++d) q(d, i) = fraction(random) * length[d];
  q(0, 3) = length[0];
  q(1, 4) = 0.0;
  q(2, 5) = -length[2];
  q(0, 6) = std::nextafter(length[0], 0.0);
  const int stride = spline_stride(p);
  std::array<std::vector<int>, 3> cell;
  std::array<std::vector<Real>, 3> value, first, second;
  MeshAtoms<Real> atoms{};
  atoms.n = n;
  for (int d = 0; d < 3; ++d) {
    atoms.scale[d] = n[d] / length[d];
    cell[d].assign(n_atoms, -1);
    value[d].assign(std::size_t(n_atoms) * stride, Real(-1));
    first[d] = second[d] = value[d];
    atoms.cell[d] = cell[d].data();
    atoms.value[d] = value[d].data();
    atoms.first[d] = first[d].data();
    atoms.second[d] = second[d].data();
  }
  const int begin = 1;
  kernels.splines(atoms, q.data(), true, begin, n_atoms);
  const double tolerance = std::is_same_v<Real, float> ? 2e-6 : 1e-14;
  for (int i = begin; i < n_atoms; ++i)
    for (int d = 0; d < 3; ++d) {
      double u = q(d, i) * atoms.scale[d];
      u -= n[d] * std::floor(u / n[d]);
      const int c = static_cast<int>(u);
      EXPECT_EQ(cell[d][i], c % n[d]) << what << " atom " << i << " dim " << d;
      SplineWeights<double> w{};
      spline_weights(u - c, p, true, w);
      for (int k = 0; k < stride; ++k) {
        const std::size_t at = std::size_t(i) * stride + k;
        EXPECT_NEAR(value[d][at], k < p ? w.value[k] : 0.0, tolerance) << what << " atom " << i << " k " << k;
        EXPECT_NEAR(first[d][at], k < p ? w.first[k] : 0.0, tolerance) << what << " atom " << i << " k " << k;
        EXPECT_NEAR(second[d][at], k < p ? w.second[k] : 0.0, 4 * tolerance) << what << " atom " << i << " k " << k;
      }
    }
  for (int d = 0; d < 3; ++d) EXPECT_EQ(cell[d][0], -1) << what << ": an atom before begin was written";
}

TEST(EwaldMesh, KernelSplinesMatchTheWeightsAtomByAtom) {
  for (const std::string& target : simd::available_targets()) {
    simd::use_target(target);
    for (int order : {3, 4, 5, 8}) {
      expect_kernel_splines_match(mesh_kernels(order), order, target + " double p=" + std::to_string(order));
      expect_kernel_splines_match(single_mesh_kernels(order), order, target + " float p=" + std::to_string(order));
    }
  }
  simd::use_target("");
}

TEST(EwaldMesh, ForcesOnlyPassSkipsNoForce) {
  const auto [system, q] = small_water();
  EwaldMeshTerm term(system, parameters({16, 15, 14}, 4), false);
  const auto with_energy = evaluate(term, q);
  Coords f = Coords::Zero(3, q.cols());
  term.add_forces(q, f, {});
  EXPECT_EQ(f, with_energy.f);
}

}  // namespace
}  // namespace vimd
