// PME's real-space form: β and the grid as GROMACS chooses them, the SIMD erfc and rational
// corrections against the standard library, and the nonbonded term's real-space energy, exclusion
// and self terms included, against a direct sum.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <utility>

#include "engine/errors.hpp"
#include "tests/pair_form_kernels.hpp"
#include "forcefields/nonbonded/nonbonded_pair_term.hpp"
#include "test_forces_common.hpp"

namespace vimd {
namespace {

// The scalar (double) instantiations of the pair kernels, from the build's static SIMD target.
using namespace vimd::HWY_NAMESPACE;

using testing::evaluate;
using testing::manual_switch;

// β as GROMACS finds it (erfc(β r) = rtol by bisection: GROMACS 2022's log for rc 0.9 nm, rtol 1e-5
// reads "Gaussian width (1/beta) of 0.288146 nm"), and its grid sizes (grompp on a 3.00129 nm box:
// 28 for spacing 0.12, 20 for 0.16, 52 for 0.06, 104 for 0.03, 128 for 0.025, 144 for 0.0215).
TEST(EwaldRealSpace, BetaAndGridAsGromacsChoosesThem) {
  const double beta = ewald_beta(0.9, 1e-5);
  EXPECT_NEAR(1 / beta, 0.288146, 5e-7);
  EXPECT_NEAR(std::erfc(beta * 0.9), 1e-5, 1e-15);
  Box box;
  box.length = Vec3::Constant(3.00129);
  ForceFieldConfig config;
  config.coulomb = "pme";
  for (auto [spacing, n] : {std::pair{0.12, 28}, {0.16, 20}, {0.06, 52}, {0.03, 104}, {0.025, 128}, {0.0215, 144}}) {
    config.fourier_spacing = spacing;
    EXPECT_EQ(pme_grid_size(config, box), (std::array<int, 3>{n, n, n})) << "spacing " << spacing;
  }
  config.fourier_spacing = 1.0;  // 4 points wanted, but order 8 needs 2 (8 − 1) = 14
  config.pme_order = 8;
  EXPECT_EQ(pme_grid_size(config, box)[0], 14);
  config.fourier_n = {13, 0, 0};
  EXPECT_THROW(pme_grid_size(config, box), InputError);
  config.fourier_n = {14, 30, 17};
  EXPECT_EQ(pme_grid_size(config, box), (std::array<int, 3>{14, 30, 17}));
  box.length[2] = 0;
  EXPECT_THROW(pme_grid_size(config, box), InputError);
}

// The vector erfc (Cody's three ranges, each where a lane needs it) against std::erfc, lanes of one
// vector spanning the ranges, in double and in single precision.
TEST(EwaldRealSpace, VectorErfcMatchesTheStandardLibrary) {
  for (double x0 = 0; x0 < 6; x0 += 0.0037) {
    double xs[16], erfc[16], gauss[16];
    for (int k = 0; k < 16; ++k) xs[k] = x0 + 0.41 * k * (k % 3);
    SimdDouble e, g;
    ewald_erfc(simd_load(xs), e, g);
    simd_store(erfc, e);
    simd_store(gauss, g);
    float xf[16], erfc_f[16], gauss_f[16];
    for (int k = 0; k < 16; ++k) xf[k] = static_cast<float>(xs[k]);
    SimdFloat ef, gf;
    ewald_erfc(simd_load(xf), ef, gf);
    simd_store(erfc_f, ef);
    simd_store(gauss_f, gf);
    for (std::size_t k = 0; k < hn::Lanes(SimdTag()); ++k) {
      EXPECT_NEAR(erfc[k], std::erfc(xs[k]), 3e-14 * std::erfc(xs[k])) << "x = " << xs[k];
      EXPECT_NEAR(gauss[k], std::exp(-xs[k] * xs[k]), 3e-14 * std::exp(-xs[k] * xs[k])) << "x = " << xs[k];
    }
    for (std::size_t k = 0; k < hn::Lanes(SimdFloat::Tag()); ++k) {
      if (xf[k] > 4.5f) continue;  // single precision is for pairs inside the cut-off: βr < 4
      const double x = xf[k];
      EXPECT_NEAR(erfc_f[k], std::erfc(x), 2e-5 * std::erfc(x)) << "x = " << x;
      EXPECT_NEAR(gauss_f[k], std::exp(-x * x), 2e-5 * std::exp(-x * x)) << "x = " << x;
    }
  }
}

// The SIMD kernels' rational corrections, E(z) = erf(x)/x and F(z) = (erf(x)/x − 2/√π e^(−z))/z with
// z = x², in single and double precision against std::erf over their range 0 ≤ x ≤ 4.5; their errors
// count against the bare Coulomb terms they are subtracted from (1/r and 1/r³: x E and x³ F), and at
// least as 1 % of the function's value. Fitted (validation/fit_ewald_corrections.py): 3e-7 in single
// precision; in double 6e-16 (E) and 7e-12 (F).
template <class Real>
void expect_rational_corrections_match(double tolerance_e, double tolerance_f) {
  using V = SimdVec<Real>;
  const int lanes = V::lanes();
  double worst_e = 0, worst_f = 0;
  for (int k0 = 0; k0 < 4500; k0 += lanes) {
    Real z[16], e[16], f[16];
    for (int k = 0; k < lanes; ++k) z[k] = static_cast<Real>(std::pow(std::min(k0 + k, 4500) * 1e-3, 2));
    simd_store(e, ewald_energy_correction(simd_load(z)));
    simd_store(f, ewald_force_correction(simd_load(z)));
    for (int k = 0; k < lanes; ++k) {
      const double zk = z[k], x = std::sqrt(zk);
      const double erf_x = x > 0 ? std::erf(x) / x : M_2_SQRTPI;
      // below x = 0.1 from its series, 2/√π Σ (−z)^(n−1) 2n/(n! (2n+1)), n ≥ 1, to round-off
      double exact_f = 0;
      if (x > 0.1) {
        exact_f = (erf_x - M_2_SQRTPI * std::exp(-zk)) / zk;
      } else {
        double power_over_factorial = 1;  // (−z)^(n−1)/n!
        for (int n = 1; n <= 8; power_over_factorial *= -zk / ++n) exact_f += power_over_factorial * 2 * n / (2 * n + 1);
        exact_f *= M_2_SQRTPI;
      }
      worst_e = std::max(worst_e, std::abs(e[k] - erf_x) * std::max(x, 0.01 * erf_x));
      worst_f = std::max(worst_f, std::abs(f[k] - exact_f) * std::max(x * x * x, 0.01 * exact_f));
    }
  }
  EXPECT_LT(worst_e, tolerance_e) << sizeof(Real) << "-byte reals";
  EXPECT_LT(worst_f, tolerance_f) << sizeof(Real) << "-byte reals";
  EXPECT_GT(worst_f, tolerance_f * 1e-3) << "no error at all: are these the SIMD corrections?";
}
TEST(EwaldRealSpace, RationalCorrectionsMatchTheStandardLibrary) {
  expect_rational_corrections_match<float>(1e-6, 1e-6);
  expect_rational_corrections_match<double>(1e-14, 2e-11);
}

// The real-space Coulomb energy of PME from an O(N²) sum with std::erfc: interacting pairs
// f qq (erfc(βr)/r − sh), excluded pairs inside the cut-off −f qq erf(βr)/r, self −f q² β/√π, as
// GROMACS's Coulomb (SR); unshifted, potential-shift and switched (then β from the switch's start).
TEST(NonbondedPairTerm, EwaldRealSpaceIncludesGromacsExclusionAndSelfTerms) {
  auto [system, q] = testing::water_like_system(10, Vec3(2.0, 2.1, 1.9), 3);
  for (const char* modifier : {"none", "potential-shift", "potential-switch"}) {
    auto config = testing::pair_config("potential-shift", "pme");
    config.coulomb_modifier = modifier;
    config.coulomb_switch = 0.6;
    const bool switched = config.coulomb_modifier == "potential-switch";
    NonbondedPairTerm term(system, config);
    const double rc = config.cutoff, f = 138.935458;
    const double beta = ewald_beta(switched ? 0.6 : rc, config.ewald_rtol);
    const double shift = config.coulomb_modifier == "potential-shift" ? std::erfc(beta * rc) / rc : 0.0;
    double expected = 0;
    for (int i = 0; i < system.n_atoms(); ++i) {
      expected -= f * system.charge[i] * system.charge[i] * beta / std::sqrt(M_PI);
      for (int j = i + 1; j < system.n_atoms(); ++j) {
        const double r = system.box.minimum_image(q.col(i) - q.col(j)).norm();
        if (r >= rc) continue;
        const double qq = f * system.charge[i] * system.charge[j];
        if (system.molecule[i] == system.molecule[j])
          expected -= qq * std::erf(beta * r) / r;
        else
          expected += qq * (std::erfc(beta * r) / r - shift) * (switched ? manual_switch(r, 0.6, rc) : 1.0);
      }
    }
    const auto result = evaluate(term, q);
    EXPECT_NEAR(result.energies[1], expected, 1e-12 * std::abs(expected)) << modifier;
  }
}

}  // namespace
}  // namespace vimd
