#pragma once
// Harmonic improper dihedral (GROMACS dihedral type 2):
//   V(ξ) = ½ k (ξ − ξ0)², with ξ − ξ0 taken in [−π, π) as GROMACS does (make_dp_periodic), so
//   that ξ0 near ±π does not meet the jump of ξ from π to −π; the force jumps only half a turn
//   away from ξ0 (where the energy, ½ k π², is continuous).
//   Units: ξ, ξ0 rad; k kJ/mol/rad².
#include <numbers>

#include "engine/system.hpp"
#include "forcefields/dual.hpp"

namespace vimd {

// V(ξ), and dV/dξ in dv_dxi.
template <class T>
T harmonic_improper_energy(const HarmonicImproper& t, T xi, T& dv_dxi) {
  constexpr double pi = std::numbers::pi;
  T dxi = xi - t.xi0;
  if (value_of(dxi) >= pi) dxi = dxi - 2 * pi;
  else if (value_of(dxi) < -pi) dxi = dxi + 2 * pi;
  dv_dxi = t.force_constant * dxi;
  return 0.5 * t.force_constant * (dxi * dxi);
}

}  // namespace vimd
