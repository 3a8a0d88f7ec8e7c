#pragma once
// The real-space part of smooth particle-mesh Ewald (coulomb = "pme"), as GROMACS's Verlet scheme
// computes it; the mesh part is ewald_mesh.hpp, docs/pme.md tells both.
//   V(r) = f qi qj/eps_r (erfc(βr)/r − sh) for r < rc, sh = erfc(β rc)/rc with potential-shift, else 0;
//   excluded pairs inside the cut-off: −f qi qj/eps_r erf(βr)/r (what the mesh counts of a pair
//   that should not interact, taken back; not shifted), self: −f qi²/eps_r β/√π.
// β follows from ewald_rtol as GROMACS finds it (ewald_beta). With coulomb_modifier =
// "potential-switch" (not in GROMACS) the pair potential is erfc(βr)/r·S(r − r_switch), and β is
// chosen so that erfc(β r_switch) = ewald_rtol: the switch then acts where the real-space term is
// already below the tolerance, so the physics stays PME's while the potential becomes C^k.
//
// The kernels (ewald_kernels.h) use the convention of lennard_jones.hpp: g = −φ'/r, a = φ'/r,
// b = (φ'' − φ'/r)/r²; qq already includes f/eps_r.
#include <array>
#include <string>

#include "engine/box.hpp"
#include "engine/system.hpp"
#include "forcefields/ewald_mesh.hpp"
#include "forcefields/nonbonded/pair_form.hpp"
#include "forcefields/nonbonded/switch_function.hpp"

namespace vimd {

// One kernel each: none and potential-shift differ only in the shift constant (0 for none).
enum class EwaldModifier { shifted, potential_switch };

// A pair form (pair_form.hpp), present with coulomb = "pme".
struct EwaldRealSpace {
  static constexpr PairEnergy kEnergy = PairEnergy::coulomb;
  static constexpr PairParameters kParameters = PairParameters::charge_product;
  static constexpr std::array kVariants{EwaldModifier::shifted, EwaldModifier::potential_switch};
  static constexpr bool kExcludedPairs = true;
  static EwaldRealSpace from_config(const ForceFieldConfig& config);
  bool present() const { return enabled; }
  EwaldModifier variant() const { return modifier; }
  int continuity(double cutoff) const;
  double self_energy(double sum_q2) const;
  std::string describe(double cutoff) const;

  bool enabled = false;
  EwaldModifier modifier = EwaldModifier::shifted;
  double prefactor = 0;  // f / eps_r, kJ/mol nm e⁻²
  double beta = 0;       // nm⁻¹
  double shift = 0;      // nm⁻¹: erfc(β rc)/rc with potential-shift, 0 otherwise
  double ewald_rtol = 0;
  SwitchFunction sw;     // potential_switch only
  // The SIMD kernels' rational corrections (ewald_kernels.h) are fitted for βr ≤ kRationalRange; beyond
  // it (a tiny ewald_rtol or a long switch) the kernels use erfc.
  static constexpr double kRationalRange = 4.5;
  bool rational_corrections = false;
};

// β such that erfc(β r) = rtol, found as GROMACS's calc_ewaldcoeff_q finds it (bisection), so that
// both programs use the same β to the last bit.
double ewald_beta(double r, double rtol);

// The distance at which the configuration's real-space term reaches ewald_rtol: the cut-off, or the
// start of the switch.
double ewald_rtol_distance(const ForceFieldConfig& config);

// The RMS force errors of PME's two parts, kJ/mol/nm, for the system's charges spread evenly
// through the box, as GROMACS's `gmx pme_error` estimates them: the real space's at
// r = ewald_rtol_distance (Kolafa and Perram 1992: 2 Σq² exp(−β² r²) / √(N r V) · f/ε_r), which is
// what ewald_rtol promises, and the mesh's on `grid` (ewald_mesh_force_error).
struct PmeForceErrors {
  double real_space;
  MeshForceError mesh;
};
PmeForceErrors pme_force_errors(const ForceFieldConfig& config, const System& system, const Box& box,
                                const std::array<int, 3>& grid);

// The setting the grid comes from: "fourier_spacing" when it sizes a direction, else "fourier_nx".
std::string pme_grid_key(const ForceFieldConfig& config);

// The mesh's grid points along x, y, z: fourier_nx/ny/nz where given, else the smallest size GROMACS
// (grompp's calcFftGrid) picks for fourier_spacing, at least 2 (pme_order − 1) per dimension, as
// GROMACS demands. SettingError for a given size below that minimum, a non-periodic box, and a grid
// of more than kMaxFourierPoints along a direction or more memory than the machine has
// (ewald_mesh_bytes): checked before anything is allocated.
std::array<int, 3> pme_grid_size(const ForceFieldConfig& config, const Box& box);

// For vimd check: β and where it comes from, the grid, the order, the mesh's smoothness and the
// estimated force errors of both parts for the system's charges.
std::string describe_pme(const ForceFieldConfig& config, const System& system);

}  // namespace vimd
