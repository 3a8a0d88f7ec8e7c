#pragma once
// Lennard-Jones pair potential with GROMACS's Verlet-scheme modifiers, V = 0 for r ≥ rc:
//   V(r) = c12/r¹² − c6/r⁶ [none]; − (c12/rc¹² − c6/rc⁶) [potential-shift]; GROMACS force-switch; potential-switch
//   V·S(r − r_switch) with the switch of switch_function.hpp (smoothness 2 = GROMACS's).
//   Units: r nm, c6 kJ/mol nm⁶, c12 kJ/mol nm¹², V kJ/mol.
//
// The kernels (lennard_jones_kernels.h) return, per pair at distance r (d = r_i − r_j):
//   energy_force: φ and g = −φ'(r)/r, so the force on i is g d;
//   hessian:      a = φ'(r)/r and b = (φ'' − φ'/r)/r², so the pair Hessian block is a I + b d dᵀ.
// They are branch-free templates on the number type T: double for reference sums, SimdDouble
// (simd/simd-inl.h) for the pair loop, which evaluates one SIMD vector of j atoms at once.
#include <array>
#include <string>

#include "forcefields/nonbonded/pair_form.hpp"
#include "forcefields/nonbonded/switch_function.hpp"

namespace vimd {

enum class VdwModifier { none, potential_shift, force_switch, potential_switch };

// "none" | "potential-shift" | "force-switch" | "potential-switch"; throws InputError otherwise.
VdwModifier parse_vdw_modifier(const std::string& name);

// Constants of a modifier, per unit coefficient of the r⁻⁶ and r⁻¹² parts (GROMACS manual,
// "Modified non-bonded interactions"; forcerec.cpp force_switch_constants / potential_switch_constants).
// A pair form (pair_form.hpp), always present; its kernels read c6 and c12 of the atoms' types.
struct LjConstants {
  static constexpr PairEnergy kEnergy = PairEnergy::vdw;
  static constexpr PairParameters kParameters = PairParameters::lennard_jones;
  static constexpr std::array kVariants{VdwModifier::none, VdwModifier::potential_shift, VdwModifier::force_switch,
                                        VdwModifier::potential_switch};
  static constexpr VdwModifier kUnswitched = VdwModifier::none;
  static LjConstants from_config(const ForceFieldConfig& config);
  bool present() const { return true; }
  VdwModifier variant() const { return modifier; }
  int continuity(double cutoff) const;
  std::string describe(double cutoff) const;  // for vimd check: the smoothness and what limits it
  bool potential_switched() const { return modifier == VdwModifier::potential_switch; }
  const SwitchFunction& potential_switch() const { return sw; }

  VdwModifier modifier = VdwModifier::none;
  double cutoff = 0, r_switch = 0;
  // Constant added to r⁻ᵖ: −rc⁻ᵖ for potential-shift, −C_p for force-switch, 0 otherwise.
  double shift6 = 0, shift12 = 0;
  // Force switch: −dV_p/dr = p r^-(p+1) + A_p x² + B_p x³, V_p = r⁻ᵖ − A_p/3 x³ − B_p/4 x⁴ − C_p, x = r − r_switch ≥ 0.
  double a6 = 0, b6 = 0, a12 = 0, b12 = 0;
  // Potential switch: V → V·S(r − r_switch).
  SwitchFunction sw;
};

// r_switch is used by the switched modifiers only and must then satisfy 0 ≤ r_switch < cutoff;
// smoothness (switch_smoothness) by potential-switch only.
LjConstants make_lj_constants(VdwModifier modifier, double cutoff, double r_switch, int smoothness = 2);

// n such that the LJ pair potential is C^n over the whole range, r_switch and cut-off included
// (−1: the energy itself jumps at the cut-off): none −1, potential-shift 0, force-switch 2,
// potential-switch the switch smoothness.
int lj_continuity(VdwModifier modifier, int smoothness);

}  // namespace vimd
