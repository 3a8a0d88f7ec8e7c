// The Lennard-Jones pair form's kernel against GROMACS's published definitions of its modifiers
// (reference manual, "Modified non-bonded interactions"), written here independently.
#include <gtest/gtest.h>

#include <cmath>

#include "engine/errors.hpp"
#include "tests/pair_form_kernels.hpp"
#include "test_forces_common.hpp"

namespace vimd {
namespace {

// The scalar (double) instantiations of the pair kernels, from the build's static SIMD target.
using namespace vimd::HWY_NAMESPACE;
using testing::lj_energy_force;

using testing::manual_switch;

double manual_force_switch_potential(double p, double r, double r1, double rc) {
  const double a = -p * ((p + 4) * rc - (p + 1) * r1) / (std::pow(rc, p + 2) * std::pow(rc - r1, 2));
  const double b = p * ((p + 3) * rc - (p + 1) * r1) / (std::pow(rc, p + 2) * std::pow(rc - r1, 3));
  const double c = 1 / std::pow(rc, p) - a / 3 * std::pow(rc - r1, 3) - b / 4 * std::pow(rc - r1, 4);
  if (r < r1) return 1 / std::pow(r, p) - c;
  return 1 / std::pow(r, p) - a / 3 * std::pow(r - r1, 3) - b / 4 * std::pow(r - r1, 4) - c;
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

}  // namespace
}  // namespace vimd
