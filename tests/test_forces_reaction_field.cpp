// The reaction-field (and plain cut-off) Coulomb form: its constants as GROMACS defines them, and
// the nonbonded term's Coulomb energy, exclusion and self terms included, against a direct sum.
#include <gtest/gtest.h>

#include <cmath>
#include <utility>

#include "engine/errors.hpp"
#include "forcefields/nonbonded/nonbonded_pair_term.hpp"
#include "tests/pair_form_kernels.hpp"
#include "test_forces_common.hpp"

namespace vimd {
namespace {

// The scalar (double) instantiations of the pair kernels, from the build's static SIMD target.
using namespace vimd::HWY_NAMESPACE;
using testing::rf_energy_force;

using testing::evaluate;
using testing::manual_switch;

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

}  // namespace
}  // namespace vimd
