#pragma once
// Ryckaert–Bellemans dihedral (GROMACS dihedral type 3, and type 5, Fourier, whose coefficients
// the topology reader converts to these as grompp does):
//   V(φ) = Σ_{n=0..5} C_n cos^n(ψ),  ψ = φ − 180° (polymer convention: ψ = 0 is trans)
//   Units: C_n kJ/mol.
#include "engine/system.hpp"
#include "forcefields/dual.hpp"

namespace vimd {

// V(φ), and dV/dφ in dv_dphi (cos ψ = −cos φ, d cos ψ/dφ = sin φ).
template <class T>
T ryckaert_bellemans_energy(const RyckaertBellemansDihedral& t, T phi, T& dv_dphi) {
  using std::cos;
  using std::sin;
  const T cos_psi = -cos(phi);
  // Horner's scheme for V and dV/d(cos ψ).
  T v = 0.0 * cos_psi + t.c[5], dv = 0.0 * cos_psi;
  for (int n = 4; n >= 0; --n) {
    dv = dv * cos_psi + v;
    v = v * cos_psi + t.c[n];
  }
  dv_dphi = dv * sin(phi);
  return v;
}

}  // namespace vimd
