// Force-field terms: kernel formulas against GROMACS's published definitions, forces against
// finite differences of the energy, Hessian–vector products against finite differences of the
// forces, for every LJ modifier and Coulomb kind.
#include <gtest/gtest.h>

#include <limits>

#include <cmath>
#include <random>
#include <sstream>

#include "engine/errors.hpp"
#include "forcefields/dihedral_angle.hpp"
#include "forcefields/dihedral_term.hpp"
#include "forcefields/harmonic_angle.hpp"
#include "forcefields/harmonic_bond.hpp"
#include "tests/pair_form_kernels.hpp"
#include "forcefields/nonbonded/nonbonded_pair_term.hpp"
#include "forcefields/pairs_14.hpp"
#include "forcefields/registry.hpp"
#include "derivative_checks.hpp"
#include "test_ff_systems.hpp"

namespace vimd {
namespace {

// The scalar (double) instantiations of the pair kernels, from the build's static SIMD target.
using namespace vimd::HWY_NAMESPACE;
using testing::lj_energy_force;
using testing::rf_energy_force;

using testing::evaluate;
using testing::expect_derivatives_match;
using testing::random_direction;
using testing::hessian_vector;
using testing::relative_difference;

// ---------------------------------------------------------------------------------------------
// Kernel formulas, written here independently from the GROMACS reference manual
// ("Modified non-bonded interactions", "Reaction field").

double manual_force_switch_potential(double p, double r, double r1, double rc) {
  const double a = -p * ((p + 4) * rc - (p + 1) * r1) / (std::pow(rc, p + 2) * std::pow(rc - r1, 2));
  const double b = p * ((p + 3) * rc - (p + 1) * r1) / (std::pow(rc, p + 2) * std::pow(rc - r1, 3));
  const double c = 1 / std::pow(rc, p) - a / 3 * std::pow(rc - r1, 3) - b / 4 * std::pow(rc - r1, 4);
  if (r < r1) return 1 / std::pow(r, p) - c;
  return 1 / std::pow(r, p) - a / 3 * std::pow(r - r1, 3) - b / 4 * std::pow(r - r1, 4) - c;
}

double manual_switch(double r, double r1, double rc) {
  if (r < r1) return 1;
  const double t = (r - r1) / (rc - r1);
  return 1 - 10 * t * t * t + 15 * t * t * t * t - 6 * t * t * t * t * t;
}

template <VdwModifier M>
double lj_value(const LjConstants& k, double c6, double c12, double r) {
  double v, g;
  lj_energy_force<M>(k, c6, c12, 1 / (r * r), r, v, g);
  return v;
}

TEST(LennardJonesKernel, MatchesGromacsManualDefinitions) {
  const double c6 = 0.0026173456, c12 = 2.634129e-6, rc = 0.9, r1 = 0.7;
  const auto none = make_lj_constants(VdwModifier::none, rc, 0);
  const auto shift = make_lj_constants(VdwModifier::potential_shift, rc, 0);
  const auto fsw = make_lj_constants(VdwModifier::force_switch, rc, r1);
  const auto psw = make_lj_constants(VdwModifier::potential_switch, rc, r1);
  for (double r : {0.25, 0.3, 0.5, 0.69, 0.7, 0.75, 0.8, 0.85, 0.89}) {
    const double lj = c12 / std::pow(r, 12) - c6 / std::pow(r, 6);
    EXPECT_NEAR(lj_value<VdwModifier::none>(none, c6, c12, r), lj, 1e-12 * std::abs(lj)) << r;
    const double shifted = lj - (c12 / std::pow(rc, 12) - c6 / std::pow(rc, 6));
    EXPECT_NEAR(lj_value<VdwModifier::potential_shift>(shift, c6, c12, r), shifted, 1e-12 * std::abs(lj)) << r;
    const double fs =
        c12 * manual_force_switch_potential(12, r, r1, rc) - c6 * manual_force_switch_potential(6, r, r1, rc);
    EXPECT_NEAR(lj_value<VdwModifier::force_switch>(fsw, c6, c12, r), fs, 1e-11 * std::abs(lj)) << r;
    const double ps = lj * manual_switch(r, r1, rc);
    EXPECT_NEAR(lj_value<VdwModifier::potential_switch>(psw, c6, c12, r), ps, 1e-12 * std::abs(lj)) << r;
  }
  // The modifiers bring potential (and for the switches the force) to zero at the cut-off.
  const double r = rc * (1 - 1e-12);
  double v, g;
  lj_energy_force<VdwModifier::potential_shift>(shift, c6, c12, 1 / (r * r), r, v, g);
  EXPECT_NEAR(v, 0, 1e-12);
  lj_energy_force<VdwModifier::force_switch>(fsw, c6, c12, 1 / (r * r), r, v, g);
  EXPECT_NEAR(v, 0, 1e-12);
  EXPECT_NEAR(g, 0, 1e-9);
  lj_energy_force<VdwModifier::potential_switch>(psw, c6, c12, 1 / (r * r), r, v, g);
  EXPECT_NEAR(v, 0, 1e-12);
  EXPECT_NEAR(g, 0, 1e-9);
}

TEST(LennardJonesKernel, RejectsBadModifierSettings) {
  EXPECT_THROW(parse_vdw_modifier("shift"), InputError);
  EXPECT_THROW(make_lj_constants(VdwModifier::potential_switch, 0.9, 0.9), InputError);
  EXPECT_THROW(make_lj_constants(VdwModifier::force_switch, 0.9, -0.1), InputError);
}

TEST(ReactionFieldKernel, MatchesGromacsDefinitions) {
  const double rc = 0.9, f = 138.935458;
  const auto infinite = make_reaction_field("reaction-field", 1.0, 0.0, rc);
  EXPECT_DOUBLE_EQ(infinite.k_rf, 1 / (2 * rc * rc * rc));
  EXPECT_DOUBLE_EQ(infinite.c_rf, 3 / (2 * rc));
  const auto rf78 = make_reaction_field("reaction-field", 1.0, 78.0, rc);
  EXPECT_DOUBLE_EQ(rf78.k_rf, 77.0 / (157.0 * rc * rc * rc));
  EXPECT_DOUBLE_EQ(rf78.c_rf, 1 / rc + rf78.k_rf * rc * rc);
  // GROMACS's plain cut-off in the Verlet scheme: k_rf = 0, c_rf = 1/rc.
  const auto cut = make_reaction_field("cutoff", 1.0, 0.0, rc);
  EXPECT_DOUBLE_EQ(cut.k_rf, 0.0);
  EXPECT_DOUBLE_EQ(cut.c_rf, 1 / rc);
  EXPECT_DOUBLE_EQ(cut.prefactor, f);
  EXPECT_EQ(make_reaction_field("none", 1.0, 0.0, rc).kind, CoulombKind::none);
  EXPECT_THROW(make_reaction_field("pme", 1.0, 0.0, rc), InputError);
  EXPECT_THROW(make_reaction_field("reaction-field", 1.0, -2.0, rc), InputError);
  // V(rc) = 0 for an interacting pair.
  double v, g;
  for (const auto& rf : {infinite, rf78, cut}) {
    rf_energy_force<CoulombModifier::none>(rf, 1.0, 1 / rc, rc * rc, v, g);
    EXPECT_NEAR(v, 0, 1e-13);
  }
}

// The Coulomb energy of a small system from an O(N²) sum written with the formulas above:
// interacting pairs f qq (1/r + k r² − c), excluded pairs f qq (k r² − c), self −½ f q² c; with
// coulomb_modifier = potential-switch (smoothness 2) both pair terms times GROMACS's quintic switch,
// here started at 0.05 nm so that the intramolecular (excluded) pairs are switched too.
TEST(NonbondedPairTerm, CoulombIncludesGromacsExclusionAndSelfTerms) {
  auto [system, q] = testing::water_like_system(10, Vec3(2.0, 2.1, 1.9), 3);
  for (auto [eps_rf, switched] : {std::pair{0.0, false}, {78.0, false}, {0.0, true}, {78.0, true}}) {
    auto config = testing::pair_config("potential-shift", "reaction-field", eps_rf);
    if (switched) {
      config.coulomb_modifier = "potential-switch";
      config.coulomb_switch = 0.05;
    }
    NonbondedPairTerm term(system, config);
    const double rc = config.cutoff;
    const double k = eps_rf == 0 ? 1 / (2 * rc * rc * rc) : (eps_rf - 1) / ((2 * eps_rf + 1) * rc * rc * rc);
    const double c = 1 / rc + k * rc * rc;
    const double f = 138.935458;
    double expected = 0, expected_lj = 0;
    for (int i = 0; i < system.n_atoms(); ++i) {
      expected -= 0.5 * f * system.charge[i] * system.charge[i] * c;
      for (int j = i + 1; j < system.n_atoms(); ++j) {
        const double r = system.box.minimum_image(q.col(i) - q.col(j)).norm();
        if (r >= rc) continue;
        const bool excluded = system.molecule[i] == system.molecule[j];
        const double qq = f * system.charge[i] * system.charge[j];
        expected += qq * ((excluded ? 0 : 1 / r) + k * r * r - c) * (switched ? manual_switch(r, 0.05, rc) : 1.0);
        if (!excluded) {
          const double c6 = system.c6(system.type[i], system.type[j]), c12 = system.c12(system.type[i], system.type[j]);
          expected_lj += c12 * (std::pow(r, -12) - std::pow(rc, -12)) - c6 * (std::pow(r, -6) - std::pow(rc, -6));
        }
      }
    }
    const auto result = evaluate(term, q);
    EXPECT_NEAR(result.energies[0], expected_lj, 1e-12 * std::abs(expected_lj));
    EXPECT_NEAR(result.energies[1], expected, 1e-12 * std::abs(expected));
  }
}

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

// ---------------------------------------------------------------------------------------------
// Finite differences for every modifier × Coulomb kind.

struct PairCase {
  std::string modifier, coulomb;
  double epsilon_rf;
};

void PrintTo(const PairCase& c, std::ostream* os) {
  *os << c.modifier << "/" << c.coulomb << "/eps_rf=" << c.epsilon_rf;
}

// 12 water-like molecules with no pair within 2e-4 nm of the cut-off, where the energy (LJ none)
// or the force (potential-shift) jumps and finite differences (steps up to 2e-5 nm) would mislead.
testing::TestSystem system_away_from_cutoff(const Vec3& box, const Vec3& extent, double cutoff) {
  for (std::uint64_t seed = 1;; ++seed) {
    auto t = testing::water_like_system(12, box, seed, extent);
    double gap = INFINITY;
    testing::for_each_pair_distance(t.system, t.q,
                                    [&](int, int, double r) { gap = std::min(gap, std::abs(r - cutoff)); });
    if (gap > 2e-4) return t;
  }
}

class PairTermDerivatives : public ::testing::TestWithParam<PairCase> {};

TEST_P(PairTermDerivatives, ForcesAndHessianVectorMatchFiniteDifferences) {
  const PairCase c = GetParam();
  const auto config = testing::pair_config(c.modifier, c.coulomb, c.epsilon_rf);
  auto [system, q] = system_away_from_cutoff(Vec3(2.0, 2.0, 2.0), Vec3::Zero(), config.cutoff);
  int in_switch_region = 0;
  testing::for_each_pair_distance(system, q, [&](int, int, double r) {
    if (r >= 0.7 && r < config.cutoff) ++in_switch_region;
  });
  ASSERT_GT(in_switch_region, 50);
  NonbondedPairTerm term(system, config);
  expect_derivatives_match(term, q, c.modifier + "/" + c.coulomb);
}

TEST_P(PairTermDerivatives, NonPeriodicSystem) {
  const PairCase c = GetParam();
  const auto config = testing::pair_config(c.modifier, c.coulomb, c.epsilon_rf);
  auto [system, q] = system_away_from_cutoff(Vec3::Zero(), Vec3(1.6, 1.4, 1.5), config.cutoff);
  NonbondedPairTerm term(system, config);
  expect_derivatives_match(term, q, c.modifier + "/" + c.coulomb + " non-periodic");
}

INSTANTIATE_TEST_SUITE_P(
    AllModifiersAndCoulombKinds, PairTermDerivatives,
    ::testing::Values(PairCase{"none", "reaction-field", 0.0}, PairCase{"potential-shift", "reaction-field", 0.0},
                      PairCase{"force-switch", "reaction-field", 0.0},
                      PairCase{"potential-switch", "reaction-field", 0.0},
                      PairCase{"potential-shift", "reaction-field", 78.0},
                      PairCase{"potential-switch", "reaction-field", 78.0}, PairCase{"potential-shift", "cutoff", 0.0},
                      PairCase{"force-switch", "cutoff", 0.0}, PairCase{"none", "none", 0.0},
                      PairCase{"potential-shift", "none", 0.0}, PairCase{"force-switch", "none", 0.0},
                      PairCase{"potential-switch", "none", 0.0}, PairCase{"none", "pme", 0.0},
                      PairCase{"potential-shift", "pme", 0.0}, PairCase{"potential-switch", "pme", 0.0}),
    [](const auto& info) {
      std::string name =
          info.param.modifier + "_" + info.param.coulomb + "_eps" + std::to_string(int(info.param.epsilon_rf));
      for (char& ch : name)
        if (ch == '-') ch = '_';
      return name;
    });

// Every vdw modifier × {unswitched, switched} Coulomb × switch smoothness 2..6, for reaction field
// (eps_rf = 78: the unswitched force jumps at rc) and plain cut-off Coulomb. The Coulomb switch
// starts at 0.6 nm, or at 0.05 nm so that the excluded intramolecular pairs are switched too.
struct SwitchCase {
  std::string vdw, coulomb, coulomb_modifier;
  int smoothness;
  double coulomb_switch;
};

void PrintTo(const SwitchCase& c, std::ostream* os) {
  *os << c.vdw << "/" << c.coulomb << "/" << c.coulomb_modifier << "/k=" << c.smoothness << "/from " << c.coulomb_switch;
}

ForceFieldConfig switch_config(const SwitchCase& c) {
  auto config = testing::pair_config(c.vdw, c.coulomb, 78.0);
  config.coulomb_modifier = c.coulomb_modifier;
  config.coulomb_switch = c.coulomb_switch;
  config.switch_smoothness = c.smoothness;
  return config;
}

class SwitchedPairTermDerivatives : public ::testing::TestWithParam<SwitchCase> {};

TEST_P(SwitchedPairTermDerivatives, ForcesAndHessianVectorMatchFiniteDifferences) {
  const SwitchCase c = GetParam();
  const auto config = switch_config(c);
  for (const Vec3& box : {Vec3(2.0, 2.0, 2.0), Vec3(0.0, 0.0, 0.0)}) {
    auto [system, q] = system_away_from_cutoff(box, Vec3(1.6, 1.4, 1.5), config.cutoff);
    NonbondedPairTerm term(system, config);
    std::ostringstream what;
    PrintTo(c, &what);
    expect_derivatives_match(term, q, what.str() + (box[0] > 0 ? "" : " non-periodic"));
  }
}

std::vector<SwitchCase> switch_cases() {
  std::vector<SwitchCase> cases;
  for (int k = 2; k <= 6; ++k)
    for (const char* vdw : {"none", "potential-shift", "force-switch", "potential-switch"})
      for (const char* modifier : {"none", "potential-switch"}) cases.push_back({vdw, "reaction-field", modifier, k, 0.6});
  for (int k : {2, 5}) {
    cases.push_back({"potential-switch", "reaction-field", "potential-switch", k, 0.7});  // LJ's switch: shared
    cases.push_back({"potential-switch", "cutoff", "potential-switch", k, 0.6});
    cases.push_back({"potential-switch", "reaction-field", "potential-switch", k, 0.05});
  }
  for (int k = 2; k <= 6; ++k) cases.push_back({"potential-switch", "pme", "potential-switch", k, 0.6});
  cases.push_back({"potential-shift", "pme", "none", 2, 0.6});  // PME unshifted: the energy jumps at rc
  return cases;
}

INSTANTIATE_TEST_SUITE_P(EveryCombination, SwitchedPairTermDerivatives, ::testing::ValuesIn(switch_cases()),
                         [](const auto& info) {
                           const SwitchCase& c = info.param;
                           std::string name = c.vdw + "_" + c.coulomb + "_" + c.coulomb_modifier + "_k" +
                                              std::to_string(c.smoothness) +
                                              (c.coulomb_switch < 0.1   ? "_from_0_05"
                                               : c.coulomb_switch == 0.7 ? "_shared_switch"
                                                                         : "");
                           for (char& ch : name)
                             if (ch == '-') ch = '_';
                           return name;
                         });

// ---------------------------------------------------------------------------------------------
// Smoothness at r_switch and at the cut-off, measured: the kernels are evaluated on truncated
// Taylor series (jets) in r, which gives every derivative of the pair potential exactly up to
// round-off, on either side of a point.

constexpr int kJetOrder = 10;  // derivatives 0..9

struct Jet {
  std::array<double, kJetOrder> c{};  // c[n] = φ⁽ⁿ⁾/n!
  static Jet constant(double x) {
    Jet j;
    j.c[0] = x;
    return j;
  }
  double derivative(int n) const { return c[n] * std::tgamma(n + 1.0); }
};
Jet operator+(Jet a, const Jet& b) {
  for (int i = 0; i < kJetOrder; ++i) a.c[i] += b.c[i];
  return a;
}
Jet operator-(Jet a, const Jet& b) {
  for (int i = 0; i < kJetOrder; ++i) a.c[i] -= b.c[i];
  return a;
}
Jet operator*(const Jet& a, const Jet& b) {
  Jet p;
  for (int i = 0; i < kJetOrder; ++i)
    for (int j = 0; i + j < kJetOrder; ++j) p.c[i + j] += a.c[i] * b.c[j];
  return p;
}
Jet operator*(Jet a, double s) {
  for (double& x : a.c) x *= s;
  return a;
}
Jet operator*(double s, const Jet& a) { return a * s; }
Jet operator+(Jet a, double s) {
  a.c[0] += s;
  return a;
}
Jet operator+(double s, const Jet& a) { return a + s; }
Jet operator-(const Jet& a, double s) { return a + (-s); }
Jet operator-(double s, const Jet& a) { return a * -1.0 + s; }
Jet reciprocal(const Jet& a) {  // 1/a by the recurrence of a·(1/a) = 1
  Jet r;
  r.c[0] = 1 / a.c[0];
  for (int n = 1; n < kJetOrder; ++n) {
    double s = 0;
    for (int i = 1; i <= n; ++i) s += a.c[i] * r.c[n - i];
    r.c[n] = -s / a.c[0];
  }
  return r;
}
// max(x, 0) for the function x(r0 + ε) at small ε > 0: the sign of its first non-zero coefficient.
Jet positive_part(const Jet& x) {
  for (double v : x.c)
    if (v != 0) return v > 0 ? x : Jet{};
  return Jet{};
}

// The pair potential φ(r0 + side·ε) as a jet in ε (side = ±1: the one-sided limit from the right
// or the left), for LJ (c6, c12 of SPC/E oxygen) or Coulomb (qq = 1).
enum class Pair { lj, coulomb };
Jet pair_potential_jet(Pair pair, const LjConstants& lj, VdwModifier vdw, const ReactionField& rf, double r0,
                       double side) {
  Jet r = Jet::constant(r0);
  r.c[1] = side;
  const Jet rinv = reciprocal(r), rinv2 = rinv * rinv, r2 = r * r;
  Jet v, g;
  if (pair == Pair::coulomb) {
    if (rf.modifier == CoulombModifier::potential_switch)
      rf_energy_force<CoulombModifier::potential_switch>(rf, Jet::constant(1.0), rinv, r2, v, g);
    else
      rf_energy_force<CoulombModifier::none>(rf, Jet::constant(1.0), rinv, r2, v, g);
    return v;
  }
  const Jet c6 = Jet::constant(0.0026173456), c12 = Jet::constant(2.634129e-6);
  switch (vdw) {
    case VdwModifier::none: lj_energy_force<VdwModifier::none>(lj, c6, c12, rinv2, r, v, g); break;
    case VdwModifier::potential_shift: lj_energy_force<VdwModifier::potential_shift>(lj, c6, c12, rinv2, r, v, g); break;
    case VdwModifier::force_switch: lj_energy_force<VdwModifier::force_switch>(lj, c6, c12, rinv2, r, v, g); break;
    case VdwModifier::potential_switch: lj_energy_force<VdwModifier::potential_switch>(lj, c6, c12, rinv2, r, v, g); break;
  }
  return v;
}

// Jumps φ⁽ⁿ⁾(r0⁺) − φ⁽ⁿ⁾(r0⁻), n = 0..9, each with the scale its round-off is measured against:
// Σ_j C(n, j) |U⁽ʲ⁾| |S⁽ⁿ⁻ʲ⁾| over the terms of the unmodified potential U (no cancellation among
// them) and the switch S (1 when unswitched), the larger of the two sides.
struct Jumps {
  std::array<double, kJetOrder> jump{}, scale{};
  // The largest n with all jumps 0..n below `relative` × scale (−1 if the value jumps).
  int continuity(double relative) const {
    for (int n = 0; n < kJetOrder; ++n)
      if (std::abs(jump[n]) > relative * scale[n]) return n - 1;
    return kJetOrder - 1;
  }
};

Jet switch_jet(const SwitchFunction& sw, double r0, double side) {
  Jet r = Jet::constant(r0), v = Jet::constant(1.0), g;
  r.c[1] = side;
  apply_switch_energy_force(sw, r, reciprocal(r), v, g);
  return v;
}

Jumps measure_jumps(Pair pair, VdwModifier vdw, const LjConstants& lj, const ReactionField& rf, double r0,
                    bool at_cutoff) {
  const Jet left = pair_potential_jet(pair, lj, vdw, rf, r0, -1.0);
  const Jet right = at_cutoff ? Jet{} : pair_potential_jet(pair, lj, vdw, rf, r0, 1.0);
  // |dⁿ r⁻ᵖ/drⁿ| = p(p+1)…(p+n−1) r^−(p+n)
  auto inverse_power = [r0](int p, int n) {
    double d = std::pow(r0, -p - n);
    for (int i = 0; i < n; ++i) d *= p + i;
    return d;
  };
  std::array<double, kJetOrder> terms{};
  for (int n = 0; n < kJetOrder; ++n)
    terms[n] = pair == Pair::lj ? 2.634129e-6 * inverse_power(12, n) + 0.0026173456 * inverse_power(6, n)
                                : inverse_power(1, n) + std::abs(rf.k_rf) * (n == 0 ? r0 * r0 : n == 1 ? 2 * r0 : n == 2 ? 2 : 0) +
                                      (n == 0 ? rf.c_rf : 0);
  const SwitchFunction* sw = pair == Pair::lj ? (vdw == VdwModifier::potential_switch ? &lj.sw : nullptr)
                                              : (rf.modifier == CoulombModifier::potential_switch ? &rf.sw : nullptr);
  // The switch's own terms in magnitude: its polynomial with every coefficient made positive.
  SwitchFunction sw_terms;
  if (sw) {
    sw_terms = *sw;
    for (auto* c : {&sw_terms.value, &sw_terms.slope, &sw_terms.curvature})
      for (double& x : *c) x = std::abs(x);
  }
  Jumps j;
  for (double side : {-1.0, 1.0}) {
    const Jet s = sw ? switch_jet(sw_terms, r0, side) : Jet::constant(1.0);
    for (int n = 0; n < kJetOrder; ++n) {
      double scale = 0, binomial = 1;
      for (int i = 0; i <= n; ++i) {
        scale += binomial * terms[i] * std::abs(s.derivative(n - i));
        binomial = binomial * (n - i) / (i + 1);
      }
      j.scale[n] = std::max(j.scale[n], scale);
    }
  }
  for (int n = 0; n < kJetOrder; ++n) {
    const double sign = n % 2 ? -1.0 : 1.0;  // the left jet is in −ε
    j.jump[n] = right.derivative(n) - sign * left.derivative(n);
  }
  return j;
}

// A jump vanishes below kVanishes × scale; the first surviving one must exceed kSurvives × scale.
// Measured for k = 2..6: vanishing jumps ≤ 1e-16 × scale, the first surviving one ≥ 2.8e-7 × scale
// (its scale, the switch's terms taken in magnitude, is pessimistic at high k).
constexpr double kVanishes = 1e-12, kSurvives = 1e-9;

int measured_continuity(Pair pair, VdwModifier vdw, const LjConstants& lj, const ReactionField& rf, double r_switch,
                        double cutoff, bool print) {
  const Jumps at_switch = measure_jumps(pair, vdw, lj, rf, r_switch, false);
  const Jumps at_cutoff = measure_jumps(pair, vdw, lj, rf, cutoff, true);
  const int n_switch = at_switch.continuity(kVanishes), n_cutoff = at_cutoff.continuity(kVanishes);
  if (print) {
    auto row = [](const char* where, const Jumps& j, int n) {
      std::printf("    %-9s C^%d; |jump|/scale for n = 0..%d:", where, n, std::min(n + 1, kJetOrder - 1));
      for (int m = 0; m <= std::min(n + 1, kJetOrder - 1); ++m) std::printf(" %.1e", std::abs(j.jump[m]) / j.scale[m]);
      std::printf("\n");
    };
    row("r_switch", at_switch, n_switch);
    row("cut-off", at_cutoff, n_cutoff);
  }
  // A surviving jump is clearly not round-off.
  for (const auto& [j, n] : {std::pair{at_switch, n_switch}, std::pair{at_cutoff, n_cutoff}})
    if (n + 1 < kJetOrder) {
      EXPECT_GT(std::abs(j.jump[n + 1]), kSurvives * j.scale[n + 1]) << "order " << n + 1;
    }
  return std::min(n_switch, n_cutoff);
}

TEST(SwitchSmoothness, DerivativeJumpsVanishUpToTheSmoothness) {
  const double rc = 0.9, lj_switch = 0.7, coulomb_switch = 0.6;
  for (int k = SwitchFunction::kMinSmoothness; k <= SwitchFunction::kMaxSmoothness; ++k) {
    SCOPED_TRACE("switch_smoothness " + std::to_string(k));
    const auto lj = make_lj_constants(VdwModifier::potential_switch, rc, lj_switch, k);
    const auto rf = make_reaction_field("reaction-field", 1.0, 78.0, rc, "potential-switch", coulomb_switch, k);
    std::printf("  k = %d, LJ potential-switch %g-%g nm:\n", k, lj_switch, rc);
    const Jumps lj_at_switch = measure_jumps(Pair::lj, VdwModifier::potential_switch, lj, rf, lj_switch, false);
    const Jumps lj_at_cutoff = measure_jumps(Pair::lj, VdwModifier::potential_switch, lj, rf, rc, true);
    EXPECT_EQ(lj_at_switch.continuity(kVanishes), k);
    EXPECT_EQ(lj_at_cutoff.continuity(kVanishes), k);
    EXPECT_EQ(measured_continuity(Pair::lj, VdwModifier::potential_switch, lj, rf, lj_switch, rc, true), k);
    // Reaction field is shifted to V(rc) = 0, so the (k+1)-th jump at the cut-off, V(rc)·S^(k+1), vanishes too.
    std::printf("  k = %d, reaction field (eps_rf 78) potential-switch %g-%g nm:\n", k, coulomb_switch, rc);
    const Jumps rf_at_switch = measure_jumps(Pair::coulomb, VdwModifier::none, lj, rf, coulomb_switch, false);
    const Jumps rf_at_cutoff = measure_jumps(Pair::coulomb, VdwModifier::none, lj, rf, rc, true);
    EXPECT_EQ(rf_at_switch.continuity(kVanishes), k);
    EXPECT_EQ(rf_at_cutoff.continuity(kVanishes), k + 1);
    EXPECT_EQ(measured_continuity(Pair::coulomb, VdwModifier::none, lj, rf, coulomb_switch, rc, true), k);
    EXPECT_EQ(coulomb_continuity(rf, rc), k);
  }
}

// What `vimd check` reports (lj_continuity, coulomb_continuity) is what the kernels do.
TEST(SwitchSmoothness, ReportedContinuityMatchesTheMeasuredOne) {
  const double rc = 0.9, r_switch = 0.7;
  for (auto vdw : {VdwModifier::none, VdwModifier::potential_shift, VdwModifier::force_switch,
                   VdwModifier::potential_switch})
    for (int k : {2, 4}) {
      const auto lj = make_lj_constants(vdw, rc, r_switch, k);
      const auto rf = make_reaction_field("none", 1.0, 0.0, rc);
      EXPECT_EQ(measured_continuity(Pair::lj, vdw, lj, rf, r_switch, rc, true), lj_continuity(vdw, k))
          << static_cast<int>(vdw) << " k " << k;
    }
  const auto lj = make_lj_constants(VdwModifier::none, rc, 0);
  for (const auto& rf : {make_reaction_field("reaction-field", 1.0, 0.0, rc), make_reaction_field("reaction-field", 1.0, 78.0, rc),
                         make_reaction_field("cutoff", 1.0, 0.0, rc),
                         make_reaction_field("cutoff", 1.0, 0.0, rc, "potential-switch", 0.5, 3)}) {
    EXPECT_EQ(measured_continuity(Pair::coulomb, VdwModifier::none, lj, rf, 0.5, rc, true), coulomb_continuity(rf, rc))
        << "k_rf " << rf.k_rf;
  }
  EXPECT_EQ(coulomb_continuity(make_reaction_field("reaction-field", 1.0, 0.0, rc), rc), 1);
  EXPECT_EQ(coulomb_continuity(make_reaction_field("reaction-field", 1.0, 78.0, rc), rc), 0);
}

TEST(SwitchSmoothness, BadSettingsAreRefused) {
  EXPECT_THROW(make_lj_constants(VdwModifier::potential_switch, 0.9, 0.7, 1), InputError);
  EXPECT_THROW(make_lj_constants(VdwModifier::potential_switch, 0.9, 0.7, 7), InputError);
  EXPECT_THROW(make_reaction_field("reaction-field", 1.0, 0.0, 0.9, "potential-switch", 0.9, 2), InputError);
  EXPECT_THROW(make_reaction_field("reaction-field", 1.0, 0.0, 0.9, "shift", 0.5, 2), InputError);
  EXPECT_THROW(make_reaction_field("none", 1.0, 0.0, 0.9, "potential-switch", 0.5, 2), InputError);
}

// A Hessian–vector product handed the cut-off masks of a force pass at the same positions takes
// them; it must give exactly what the full pass gives, and take them only for the list they belong to.
TEST(NonbondedPairTerm, HessianReuseOfForcePassIsExact) {
  auto [system, q] = testing::water_like_system(200, Vec3(2.5, 2.5, 2.5), 9);
  const auto config = testing::pair_config("potential-switch", "reaction-field", 78.0);
  const Coords u = random_direction(system.n_atoms(), 4);
  NonbondedPairTerm fresh(system, config), reused(system, config);
  const Coords reference = hessian_vector(fresh, q, u);  // no force evaluation: full pass
  EXPECT_EQ(fresh.reused_masks(), 0);
  TermMasks masks;
  TermEvaluation keep;
  keep.keep_masks = &masks;
  evaluate(reused, q, keep);
  TermEvaluation with_masks;
  with_masks.masks = &masks;
  const Coords again = hessian_vector(reused, q, u, with_masks);
  EXPECT_EQ(reused.reused_masks(), 1);
  EXPECT_EQ((again - reference).cwiseAbs().maxCoeff(), 0.0);
  // Several stage positions in a row, then their products in reverse order (as an RK reverse pass).
  std::vector<Coords> stages;
  std::vector<TermMasks> stage_masks(5);
  for (int k = 0; k < 5; ++k) {
    stages.push_back(q + 1e-3 * k * u);
    keep.keep_masks = &stage_masks[k];
    evaluate(reused, stages.back(), keep);
  }
  for (int k = 4; k >= 0; --k) {
    with_masks.masks = &stage_masks[k];
    EXPECT_EQ((hessian_vector(reused, stages[k], u, with_masks) - hessian_vector(fresh, stages[k], u))
                  .cwiseAbs()
                  .maxCoeff(),
              0.0);
  }
  EXPECT_EQ(reused.reused_masks(), 6);
  // After the list has changed (moved far enough to prune again), masks of the old list are not taken.
  const Coords far = q + 0.2 * u / u.cwiseAbs().maxCoeff();
  with_masks.masks = &masks;
  const Coords at_far = hessian_vector(reused, far, u, with_masks);
  EXPECT_EQ(reused.reused_masks(), 6);
  EXPECT_EQ((at_far - hessian_vector(fresh, far, u)).cwiseAbs().maxCoeff(), 0.0);
}

TEST(HarmonicBondTerm, DerivativesMatchFiniteDifferences) {
  auto [system, q] = testing::water_like_system(6, Vec3(2.0, 2.0, 2.0), 21);
  // Molecules straddling the box edge exercise the minimum image.
  q.row(0).array() += 1.95;
  HarmonicBondTerm term(system.bonds, system.box);
  EXPECT_EQ(term.energy_names(), std::vector<std::string>{"bonds"});
  expect_derivatives_match(term, q, "bonds");
  double expected = 0;
  for (const Bond& b : system.bonds) {
    const double r = system.box.minimum_image(q.col(b.i) - q.col(b.j)).norm();
    expected += 0.5 * b.k * (r - b.length) * (r - b.length);
  }
  EXPECT_NEAR(evaluate(term, q).energy, expected, 1e-12 * expected);
}

TEST(HarmonicAngleTerm, DerivativesMatchFiniteDifferences) {
  auto [system, q] = testing::water_like_system(6, Vec3(2.0, 2.0, 2.0), 22);
  q.row(1).array() += 1.95;
  HarmonicAngleTerm term(system.angles, system.box);
  EXPECT_EQ(term.energy_names(), std::vector<std::string>{"angles"});
  expect_derivatives_match(term, q, "angles");
  double expected = 0;
  for (const Angle& a : system.angles) {
    const Vec3 u = system.box.minimum_image(q.col(a.i) - q.col(a.j)),
               v = system.box.minimum_image(q.col(a.k) - q.col(a.j));
    const double theta = std::acos(u.dot(v) / (u.norm() * v.norm()));
    expected += 0.5 * a.force_constant * (theta - a.theta0) * (theta - a.theta0);
  }
  EXPECT_NEAR(evaluate(term, q).energy, expected, 1e-10 * expected);
}

TEST(HarmonicAngleTerm, NearlyStraightAngle) {
  System system;
  system.box.length = Vec3::Zero();
  Coords q(3, 3);
  q << 0.1, 0.0, -0.1, 0.0, 0.0, 0.003, 0.0, 0.0, 0.0;
  HarmonicAngleTerm term({{0, 1, 2, 2.0, 400.0}}, system.box);
  expect_derivatives_match(term, q, "angle near 180 degrees");
}

// A term of constant energies, for the field's bookkeeping of energy columns.
class ConstantEnergyTerm : public ForceTerm {
 public:
  ConstantEnergyTerm(std::vector<std::string> names, std::vector<std::string> part_of, std::vector<double> values)
      : names_(std::move(names)), part_of_(std::move(part_of)), values_(std::move(values)) {}
  std::vector<std::string> energy_names() const override { return names_; }
  std::vector<std::string> energy_part_of() const override { return part_of_; }
  void add_forces(const Coords&, Coords&, std::span<double> energies, const TermEvaluation&) override {
    for (std::size_t k = 0; k < energies.size(); ++k) energies[k] += values_[k];
  }
  void add_hessian_vector(const Coords&, const Coords&, Coords&, const TermEvaluation&) override {}
  void add_single_point(const Coords&, Coords&, std::span<double> energies) const override {
    for (std::size_t k = 0; k < energies.size(); ++k) energies[k] += values_[k];
  }

 private:
  std::vector<std::string> names_, part_of_;
  std::vector<double> values_;
};

// A column that is a part of another (the PME mesh's coulomb_recip of coulomb) is reported on its
// own, added to its total, and counted in the potential once.
TEST(ForceField, EnergyPartsAreAddedToTheirTotalAndCountedOnce) {
  ForceField field;
  field.add(std::make_unique<ConstantEnergyTerm>(std::vector<std::string>{"lj", "coulomb"}, std::vector<std::string>{},
                                                 std::vector<double>{1.0, -10.0}));
  field.add(std::make_unique<ConstantEnergyTerm>(std::vector<std::string>{"bonds", "coulomb_recip"},
                                                 std::vector<std::string>{"", "coulomb"}, std::vector<double>{5.0, 2.5}));
  EXPECT_EQ(field.energy_names(), (std::vector<std::string>{"lj", "coulomb", "bonds", "coulomb_recip"}));
  const Coords q = Coords::Zero(3, 2);
  Forces forces, single;
  field.compute(q, forces);
  field.single_point(q, single);
  for (const Forces* f : {&forces, &single}) {
    EXPECT_EQ(f->terms, (std::vector<double>{1.0, -7.5, 5.0, 2.5}));
    EXPECT_EQ(f->potential, 1.0 - 7.5 + 5.0);
  }
  ForceField wrong;
  EXPECT_THROW(wrong.add(std::make_unique<ConstantEnergyTerm>(std::vector<std::string>{"coulomb_recip"},
                                                              std::vector<std::string>{"coulomb"},
                                                              std::vector<double>{1.0})),
               std::logic_error);
}

// ---------------------------------------------------------------------------------------------
// Dihedrals and 1–4 pairs.

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

TEST(Pair14Term, EnergiesForcesAndHessianVector) {
  auto [system, q] = testing::chain_system(12, 6, Vec3(1.5, 1.6, 1.7), 32);
  ForceFieldConfig config;
  config.epsilon_r = 2.0;
  Pair14Term term(system.pairs14, system.box, config);
  EXPECT_EQ(term.energy_names(), (std::vector<std::string>{"lj14", "coulomb14"}));
  double lj = 0, coulomb = 0;
  for (const Pair14& p : system.pairs14) {
    const double r = system.box.minimum_image(q.col(p.i) - q.col(p.j)).norm();
    lj += p.c12 / std::pow(r, 12) - p.c6 / std::pow(r, 6);
    coulomb += kCoulomb / 2.0 * p.qq / r;  // f/ε_r, ε_r = 2; epsilon_rf plays no part
  }
  const auto result = evaluate(term, q);
  EXPECT_NEAR(result.energies[0], lj, 1e-12 * std::abs(lj));
  EXPECT_NEAR(result.energies[1], coulomb, 1e-12 * std::abs(coulomb));
  expect_derivatives_match(term, q, "1-4 pairs");
  config.coulomb = "none";  // no electrostatics at all
  Pair14Term uncharged(system.pairs14, system.box, config);
  const auto without = evaluate(uncharged, q);
  EXPECT_EQ(without.energies[1], 0.0);
  EXPECT_EQ(without.energies[0], result.energies[0]);
}

TEST(ForceFieldRegistry, BuildsAllTermsWithTheirEnergyNames) {
  auto [system, q] = testing::water_like_system(12, Vec3(2.0, 2.0, 2.0), 11);
  auto field = make_force_field(system, testing::pair_config("potential-switch", "reaction-field", 78.0));
  EXPECT_EQ(field->energy_names(), (std::vector<std::string>{"lj", "coulomb", "bonds", "angles", "dihedrals",
                                                              "impropers", "lj14", "coulomb14"}));
  Forces forces;
  field->compute(q, forces);
  double sum = 0;
  for (double e : forces.terms) sum += e;
  EXPECT_DOUBLE_EQ(forces.potential, sum);
  for (int k = 0; k < 4; ++k) EXPECT_NE(forces.terms[k], 0.0);
  for (int k = 4; k < 8; ++k) EXPECT_EQ(forces.terms[k], 0.0);  // water has no dihedrals or 1-4 pairs
  // The whole field obeys the same derivative checks as its terms.
  Coords hu;
  const Coords u = random_direction(system.n_atoms(), 3);
  field->hessian_vector(q, u, hu);
  Coords expected = Coords::Zero(3, q.cols());
  for (const auto& term : field->terms()) expected += hessian_vector(*term, q, u);
  EXPECT_LT(relative_difference(hu, expected), 1e-14);
  EXPECT_EQ(field->work().neighbor_rebuilds, 1);
}

// The first term (the pair term) sets the forces instead of adding to zeros, so whatever the output
// held before must not show; the later terms add theirs, as onto zeros.
TEST(ForceField, ForcesAreTheTermsSumWhateverTheOutputHeld) {
  auto [system, q] = testing::water_like_system(100, Vec3(2.2, 2.2, 2.2), 17);
  auto field = make_force_field(system, testing::pair_config("potential-shift", "reaction-field", 0.0));
  ASSERT_TRUE(field->terms().front()->writes_forces());
  for (bool energies : {true, false}) {
    Forces forces;
    forces.f.setConstant(3, q.cols(), std::numeric_limits<double>::quiet_NaN());
    if (energies)
      field->compute(q, forces);
    else
      field->compute_forces(q, forces);
    Coords expected = Coords::Zero(3, q.cols());
    for (const auto& term : field->terms()) term->add_forces(q, expected, {});
    EXPECT_EQ((forces.f - expected).cwiseAbs().maxCoeff(), 0.0) << "energies " << energies;
  }
}

// An observation (single_point) is what a fresh field computes, and leaves the field as it was:
// the run's evaluations after it are bitwise those of a run never observed, whatever positions
// were observed (here ones that would have forced a new search and pruning).
TEST(ForceField, SinglePointChangesNothingTheRunComputes) {
  auto [system, q] = testing::water_like_system(200, Vec3(2.5, 2.5, 2.5), 13);
  const auto config = testing::pair_config("potential-switch", "reaction-field", 78.0);
  auto observed = make_force_field(system, config), plain = make_force_field(system, config),
       fresh = make_force_field(system, config);
  const Coords u = random_direction(system.n_atoms(), 5);
  const Coords elsewhere = q + 0.3 * u / u.cwiseAbs().maxCoeff();
  Forces at_elsewhere, reference;
  fresh->compute(elsewhere, reference);
  const ForceField& as_observer = *observed;
  as_observer.single_point(elsewhere, at_elsewhere);
  EXPECT_EQ(at_elsewhere.terms, reference.terms);
  EXPECT_EQ((at_elsewhere.f - reference.f).cwiseAbs().maxCoeff(), 0.0);
  EXPECT_EQ(observed->work().neighbor_rebuilds, 0);
  EXPECT_EQ(observed->work().force_evaluations, 0);
  for (const Coords& at : {q, Coords(q + 1e-3 * u)}) {
    Forces a, b;
    observed->compute(at, a);
    as_observer.single_point(elsewhere, at_elsewhere);
    plain->compute(at, b);
    EXPECT_EQ(a.terms, b.terms);
    EXPECT_EQ((a.f - b.f).cwiseAbs().maxCoeff(), 0.0);
  }
  EXPECT_EQ(observed->work().neighbor_rebuilds, plain->work().neighbor_rebuilds);
  EXPECT_EQ(observed->work().neighbor_prunes, plain->work().neighbor_prunes);
}

TEST(ForceFieldRegistry, RejectsBadConfiguration) {
  auto [system, q] = testing::water_like_system(4, Vec3(2.0, 2.0, 2.0), 1);
  EXPECT_THROW(make_force_field(system, testing::pair_config("switch", "reaction-field")), InputError);
  EXPECT_THROW(make_force_field(system, testing::pair_config("potential-shift", "p3m")), InputError);
  EXPECT_THROW(make_force_field(system, testing::pair_config("potential-switch", "reaction-field", 0, 0.9, 1.0)),
               InputError);
  // The box must hold twice the cut-off.
  EXPECT_THROW(make_force_field(system, testing::pair_config("potential-shift", "reaction-field", 0, 1.1)), InputError);
}

}  // namespace
}  // namespace vimd
