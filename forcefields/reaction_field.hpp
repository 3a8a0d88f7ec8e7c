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
// Kernels use the same convention as lennard_jones.hpp (templates on double / SimdDouble):
// g = −φ'/r, a = φ'/r, b = (φ'' − φ'/r)/r²; qq already includes f/eps_r.
#include <cmath>
#include <string>

#include "engine/simd.hpp"
#include "forcefields/switch_function.hpp"

namespace vimd {

enum class CoulombKind { none, reaction_field };
enum class CoulombModifier { none, potential_switch };

struct ReactionField {
  CoulombKind kind = CoulombKind::none;
  CoulombModifier modifier = CoulombModifier::none;
  double prefactor = 0;  // f / eps_r, kJ/mol nm e⁻²
  double k_rf = 0;       // nm⁻³
  double c_rf = 0;       // nm⁻¹
  SwitchFunction sw;     // potential_switch only
};

// coulomb: "reaction-field" | "cutoff" | "none"; modifier: "none" | "potential-switch" (then
// 0 ≤ r_switch < cutoff, and coulomb must not be "none"); throws InputError for anything else or bad
// epsilons.
ReactionField make_reaction_field(const std::string& coulomb, double epsilon_r, double epsilon_rf, double cutoff,
                                  const std::string& modifier = "none", double r_switch = 0, int smoothness = 2);

// n such that the Coulomb pair potential is C^n at the cut-off and the switch: the shifted V(rc) is
// 0; its force vanishes at rc only for eps_rf = ∞ (C¹), else jumps (C⁰); switched: the smoothness.
int coulomb_continuity(const ReactionField& rf, double cutoff);

template <CoulombModifier C, class T>
inline void rf_energy_force(const ReactionField& rf, T qq, T rinv, T r2, T& v, T& g) {
  v = qq * (rinv + rf.k_rf * r2 - rf.c_rf);
  g = qq * (rinv * rinv * rinv - 2.0 * rf.k_rf);
  if constexpr (C == CoulombModifier::potential_switch) apply_switch_energy_force(rf.sw, r2 * rinv, rinv, v, g);
}

template <CoulombModifier C, class T>
inline void rf_hessian(const ReactionField& rf, T qq, T rinv, T r2, T& a, T& b) {
  const T rinv3 = rinv * rinv * rinv;
  a = qq * (2.0 * rf.k_rf - rinv3);
  b = 3.0 * qq * rinv3 * rinv * rinv;
  if constexpr (C == CoulombModifier::potential_switch)
    apply_switch_hessian(rf.sw, qq * (rinv + rf.k_rf * r2 - rf.c_rf), r2 * rinv, rinv, a, b);
}

// Excluded pair inside the cut-off: φ = qq (k_rf r² − c_rf), times S when switched (scalar code:
// few pairs, so the modifier is a run-time test).
inline void rf_excluded_energy_force(const ReactionField& rf, double qq, double r2, double& v, double& g) {
  v = qq * (rf.k_rf * r2 - rf.c_rf);
  g = -2 * qq * rf.k_rf;
  if (rf.modifier == CoulombModifier::potential_switch) {
    const double r = std::sqrt(r2);
    apply_switch_energy_force(rf.sw, r, 1 / r, v, g);
  }
}

inline void rf_excluded_hessian(const ReactionField& rf, double qq, double r2, double& a, double& b) {
  a = 2 * qq * rf.k_rf;
  b = 0;
  if (rf.modifier == CoulombModifier::potential_switch) {
    const double r = std::sqrt(r2);
    apply_switch_hessian(rf.sw, qq * (rf.k_rf * r2 - rf.c_rf), r, 1 / r, a, b);
  }
}

// −½ (f/eps_r) c_rf Σ qi²: a constant energy, no force.
inline double rf_self_energy(const ReactionField& rf, double sum_q2) { return -0.5 * rf.prefactor * rf.c_rf * sum_q2; }

}  // namespace vimd
