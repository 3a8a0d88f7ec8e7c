#pragma once
// Reaction-field Coulomb as in the GROMACS Verlet scheme, V = 0 for r ≥ rc:
//   V(r) = f qi qj/eps_r (1/r + k_rf r² − c_rf); excluded pairs (r < rc): f qi qj/eps_r (k_rf r² − c_rf); self: −½ f
//   qi² c_rf/eps_r Units: q e, r nm, f = 138.935458 kJ/mol nm e⁻², V kJ/mol; k_rf = (eps_rf − eps_r)/((2 eps_rf +
//   eps_r) rc³), c_rf = 1/rc + k_rf rc².
//
// GROMACS's "plain cut-off" Coulomb in the Verlet scheme is this same kernel with k_rf = 0 and
// c_rf = 1/rc (forcerec.cpp init_interaction_const: "For plain cut-off we might use the
// reaction-field kernels", eps_rf = eps_r; the nbnxm kernels then apply the excluded-pair and
// self terms as for reaction field). epsilon_rf = 0 means eps_rf = ∞: k_rf = 1/(2 rc³).
// The excluded-pair and self terms are what GROMACS's nbnxm kernels add (kernel_ref_inner.h:
// excluded pairs inside the cut-off keep qq (k_rf r² − c_rf); kernel_ref_outer.h: −½ qi² c_rf per atom).
//
// coulomb_modifier = "potential-switch" (not in GROMACS) multiplies the interacting-pair potential
// by the switch of switch_function.hpp: φ = V_RF(r)·S(r − r_switch), so that φ is C^k at r_switch
// and C^(k+1) at the cut-off (V_RF(rc) = 0), k = switch_smoothness; without it the RF force jumps
// at rc unless eps_rf = ∞, and its derivative jumps always. The excluded-pair term is switched the
// same way, qq (k_rf r² − c_rf)·S: it is the reaction-field part of a pair whose bare 1/r is
// excluded, so it takes the same factor as the included pairs' reaction field, and unswitched it
// would jump by −qq/rc at the cut-off for an excluded pair that reaches it (possible only in long
// molecules; water's excluded pairs stay far inside r_switch, where S = 1, so water is unchanged).
// The self term is that pair term's r → 0 limit, where S = 1: unchanged.
//
// The kernels (reaction_field_kernels.h) use the same convention as lennard_jones.hpp:
// g = −φ'/r, a = φ'/r, b = (φ'' − φ'/r)/r²; qq already includes f/eps_r.
#include <array>
#include <string>

#include "forcefields/nonbonded/pair_form.hpp"
#include "forcefields/nonbonded/switch_function.hpp"

namespace vimd {

enum class CoulombKind { none, reaction_field };
enum class CoulombModifier { none, potential_switch };

// A pair form (pair_form.hpp), present unless coulomb = "none"; its kernels read the atoms' charges.
struct ReactionField {
  static constexpr PairEnergy kEnergy = PairEnergy::coulomb;
  static constexpr PairParameters kParameters = PairParameters::charge_product;
  static constexpr std::array kVariants{CoulombModifier::none, CoulombModifier::potential_switch};
  static constexpr CoulombModifier kUnswitched = CoulombModifier::none;
  static constexpr bool kExcludedPairs = true;
  static ReactionField from_config(const ForceFieldConfig& config);
  bool present() const { return kind == CoulombKind::reaction_field; }
  CoulombModifier variant() const { return modifier; }
  int continuity(double cutoff) const;
  std::string describe(double cutoff) const;
  double self_energy(double sum_q2) const;
  bool potential_switched() const { return modifier == CoulombModifier::potential_switch; }
  const SwitchFunction& potential_switch() const { return sw; }

  CoulombKind kind = CoulombKind::none;
  CoulombModifier modifier = CoulombModifier::none;
  double prefactor = 0;  // f / eps_r, kJ/mol nm e⁻²
  double k_rf = 0;       // nm⁻³
  double c_rf = 0;       // nm⁻¹
  SwitchFunction sw;     // potential_switch only
};

// coulomb: "reaction-field" | "cutoff" | "none"; modifier: "none" | "potential-shift" | "potential-switch" (then
// 0 ≤ r_switch < cutoff, and coulomb must not be "none"); throws InputError for anything else or bad
// epsilons.
ReactionField make_reaction_field(const std::string& coulomb, double epsilon_r, double epsilon_rf, double cutoff,
                                  const std::string& modifier = "potential-shift", double r_switch = 0,
                                  int smoothness = 2);

// n such that the Coulomb pair potential is C^n at the cut-off and the switch: the shifted V(rc) is
// 0; its force vanishes at rc only for eps_rf = ∞ (C¹), else jumps (C⁰); switched: the smoothness.
int coulomb_continuity(const ReactionField& rf, double cutoff);

// −½ (f/eps_r) c_rf Σ qi²: a constant energy, no force.
inline double rf_self_energy(const ReactionField& rf, double sum_q2) { return -0.5 * rf.prefactor * rf.c_rf * sum_q2; }

inline int ReactionField::continuity(double cutoff) const { return coulomb_continuity(*this, cutoff); }
inline double ReactionField::self_energy(double sum_q2) const { return rf_self_energy(*this, sum_q2); }

}  // namespace vimd
