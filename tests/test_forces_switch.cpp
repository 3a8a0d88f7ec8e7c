// The potential switch's smoothness, measured on the pair kernels: every derivative's jump at
// r_switch and at the cut-off vanishes up to the smoothness asked for, and `vimd check` reports
// what the kernels do.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <string>
#include <utility>

#include "engine/errors.hpp"
#include "tests/pair_form_kernels.hpp"

namespace vimd {
namespace {

// The scalar (double) instantiations of the pair kernels, from the build's static SIMD target.
using namespace vimd::HWY_NAMESPACE;
using testing::lj_energy_force;
using testing::rf_energy_force;

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

}  // namespace
}  // namespace vimd
