#pragma once
// Lennard-Jones pair potential with GROMACS's Verlet-scheme modifiers, V = 0 for r ≥ rc:
//   V(r) = c12/r¹² − c6/r⁶ [none]; − (c12/rc¹² − c6/rc⁶) [potential-shift]; GROMACS force-switch; potential-switch
//   V·S(r − r_switch) with the switch of switch_function.hpp (smoothness 2 = GROMACS's).
//   Units: r nm, c6 kJ/mol nm⁶, c12 kJ/mol nm¹², V kJ/mol.
//
// The kernels return, per pair at distance r (d = r_i − r_j):
//   energy_force: φ and g = −φ'(r)/r, so the force on i is g d;
//   hessian:      a = φ'(r)/r and b = (φ'' − φ'/r)/r², so the pair Hessian block is a I + b d dᵀ.
// They are branch-free templates on the number type T: double for reference sums, SimdDouble
// (simd.hpp) for the pair loop, which evaluates 8 j atoms at once.
#include <string>

#include "engine/simd.hpp"
#include "forcefields/switch_function.hpp"

namespace vimd {

enum class VdwModifier { none, potential_shift, force_switch, potential_switch };

// "none" | "potential-shift" | "force-switch" | "potential-switch"; throws InputError otherwise.
VdwModifier parse_vdw_modifier(const std::string& name);

// Constants of a modifier, per unit coefficient of the r⁻⁶ and r⁻¹² parts (GROMACS manual,
// "Modified non-bonded interactions"; forcerec.cpp force_switch_constants / potential_switch_constants).
struct LjConstants {
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

template <VdwModifier M, class T>
inline void lj_energy_force(const LjConstants& k, T c6, T c12, T rinv2, T r, T& v, T& g) {
  const T rinv6 = rinv2 * rinv2 * rinv2;
  const T rep = c12 * rinv6 * rinv6;  // c12 r⁻¹²
  const T dis = c6 * rinv6;           // c6 r⁻⁶
  if constexpr (M == VdwModifier::none || M == VdwModifier::potential_shift) {
    v = rep - dis + (c12 * k.shift12 - c6 * k.shift6);
    g = (12.0 * rep - 6.0 * dis) * rinv2;
  } else if constexpr (M == VdwModifier::force_switch) {
    const T x = positive_part(r - k.r_switch);
    const T x2 = x * x, x3 = x2 * x;
    const T rinv = rinv2 * r;
    v = rep - dis + c12 * (k.shift12 - (k.a12 / 3 + k.b12 / 4.0 * x) * x3) -
        c6 * (k.shift6 - (k.a6 / 3 + k.b6 / 4.0 * x) * x3);
    g = (12.0 * rep - 6.0 * dis) * rinv2 + (c12 * (k.a12 + k.b12 * x) - c6 * (k.a6 + k.b6 * x)) * x2 * rinv;
  } else {  // potential_switch
    v = rep - dis;
    g = (12.0 * rep - 6.0 * dis) * rinv2;
    apply_switch_energy_force(k.sw, r, rinv2 * r, v, g);
  }
}

template <VdwModifier M, class T>
inline void lj_hessian(const LjConstants& k, T c6, T c12, T rinv2, T r, T& a, T& b) {
  const T rinv6 = rinv2 * rinv2 * rinv2;
  const T rep = c12 * rinv6 * rinv6;
  const T dis = c6 * rinv6;
  if constexpr (M == VdwModifier::none || M == VdwModifier::potential_shift) {
    a = (6.0 * dis - 12.0 * rep) * rinv2;
    b = (168.0 * rep - 48.0 * dis) * rinv2 * rinv2;
  } else if constexpr (M == VdwModifier::force_switch) {
    // Per power p: φ_p'/r = −p r^-(p+2) − (A x² + B x³)/r;
    // (φ_p'' − φ_p'/r)/r² = [p(p+2) r^-(p+2) − 2A x − 3B x² + (A x² + B x³)/r] / r².
    const T x = positive_part(r - k.r_switch);
    const T x2 = x * x;
    const T rinv = rinv2 * r;
    const T poly12 = (k.a12 + k.b12 * x) * x2, poly6 = (k.a6 + k.b6 * x) * x2;
    a = (6.0 * dis - 12.0 * rep) * rinv2 - (c12 * poly12 - c6 * poly6) * rinv;
    b = ((168.0 * rep - 48.0 * dis) * rinv2 - c12 * ((2.0 * k.a12 + 3.0 * k.b12 * x) * x - poly12 * rinv) +
         c6 * ((2.0 * k.a6 + 3.0 * k.b6 * x) * x - poly6 * rinv)) *
        rinv2;
  } else {  // potential_switch
    a = (6.0 * dis - 12.0 * rep) * rinv2;
    b = (168.0 * rep - 48.0 * dis) * rinv2 * rinv2;
    apply_switch_hessian(k.sw, rep - dis, r, rinv2 * r, a, b);
  }
}

}  // namespace vimd
