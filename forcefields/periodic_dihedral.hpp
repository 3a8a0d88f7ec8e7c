#pragma once
// Periodic dihedral (GROMACS dihedral types 1 and 9, proper; 4, periodic improper):
//   V(φ) = k (1 + cos(n φ − φs))
//   Units: φ, φs rad; k kJ/mol; n integer (multiplicity).
#include "engine/system.hpp"
#include "forcefields/dual.hpp"

namespace vimd {

// V(φ), and dV/dφ in dv_dphi.
template <class T>
T periodic_dihedral_energy(const PeriodicDihedral& t, T phi, T& dv_dphi) {
  using std::cos;
  using std::sin;
  const T angle = static_cast<double>(t.multiplicity) * phi - t.phi_s;
  dv_dphi = (-t.force_constant * t.multiplicity) * sin(angle);
  return t.force_constant * (1.0 + cos(angle));
}

}  // namespace vimd
