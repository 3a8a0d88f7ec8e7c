#pragma once
// The reciprocal-space (mesh) part of smooth particle-mesh Ewald (Essmann et al. 1995), with
// GROMACS's B-spline convention, moduli and influence function, energy "coulomb_recip" (GROMACS's
// "Coul. recip."):
//   E = f/(2πV ε_r) Σ_{m≠0} exp(−π²m²/β²) / (m² B(m)) |S(m)|²  −  π f Q² / (2 V β² ε_r)
//   S(m) = Σ_grid Q(g) e^{−2πi m·g/n}, Q the charges spread on the grid by B-splines of order p,
//   B(m) = B_x B_y B_z the splines' Fourier moduli, Q = Σ q the net charge (its term is constant).
// The real-space, self and excluded-pair parts of PME are the pair loop's. Rectangular boxes
// periodic in x, y and z; positions may be unwrapped. docs/pme.md has the formulas in full.
//
// The per-atom loops are SIMD kernels per target and order (ewald_mesh_kernels.hpp).
// Threads: one parallel region per pass. Each thread owns a slab of x planes (the transforms'
// split, fft_grid.hpp; FFTW_ESTIMATE plans: reproducible run to run) and spreads and gathers the
// atoms whose splines start there, onto a grid of its slab and the p − 1 planes after, summed in
// thread order. Results are bitwise reproducible for a given thread count and differ between
// thread counts by round-off only.
// Precision: double, or float grids and transforms (as GROMACS's mixed build) with mixed_precision
// or TermEvaluation::single_precision; energies summed in double either way.
#include <array>
#include <cmath>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "engine/force_field.hpp"
#include "engine/system.hpp"

namespace vimd {

struct EwaldMeshParameters {
  std::array<int, 3> grid;  // nx, ny, nz grid points
  int order;                // B-spline interpolation order p (GROMACS pme-order), kMinPmeOrder..kMaxPmeOrder
  double beta;              // Ewald splitting coefficient, nm⁻¹
  double prefactor;         // f/ε_r, kJ/mol nm e⁻² (f = kCoulomb)
};

// The memory one term's mesh takes, bytes, for a grid of n points (double: a grid too large for
// int is measured before it is refused): the influence function (double), and in the given
// precision the two transform grids (real and half complex each) and the threads' spreading slabs.
double ewald_mesh_bytes(const std::array<double, 3>& n, int order, bool single_precision, int threads);

// The mesh's RMS force error for charges spread evenly through the box, kJ/mol/nm, as GROMACS's
// `gmx pme_error` estimates it (Wang et al., J. Chem. Phys. 132, 244106 (2010)), in two parts:
// terms I and II, the other charges' fields, which grow as √(charge density) as the real space's
// error does, and term III, each charge's force on itself, which does not (averaged over the
// position in the grid cell, where GROMACS samples the charges' positions).
struct MeshForceError {
  double pairs, self;
  double total() const { return std::hypot(pairs, self); }
};
// sum_q2 = Σ q², sum_q4 = Σ q⁴ over the n_charges charged atoms; prefactor f/ε_r.
MeshForceError ewald_mesh_force_error(const Vec3& box, const std::array<int, 3>& n, int order, double beta,
                                      double prefactor, double sum_q2, double sum_q4, int n_charges);

// What every mesh of one term shares: grid, order, box, charges and the influence function.
struct EwaldMeshSetup;
// One precision's grids and transforms.
class EwaldMesh;

class EwaldMeshTerm : public ForceTerm {
 public:
  EwaldMeshTerm(const System& system, const EwaldMeshParameters& p, bool mixed_precision);
  ~EwaldMeshTerm() override;

  std::vector<std::string> energy_names() const override { return {"coulomb_recip"}; }
  // GROMACS's Coul. recip. is a part of the Coulomb energy.
  std::vector<std::string> energy_part_of() const override { return {"coulomb"}; }
  void add_forces(const Coords& q, Coords& f, std::span<double> energies, const TermEvaluation& how = {}) override;
  void add_hessian_vector(const Coords& q, const Coords& u, Coords& out, const TermEvaluation& how = {}) override;
  void add_single_point(const Coords& q, Coords& f, std::span<double> energies) const override;
  bool has_single_precision() const override { return true; }
  void add_work(WorkCounters& counters) const override { counters.mesh_seconds += seconds_; }

  // −π f Q² / (2 V β² ε_r): constant, included in the energy.
  double net_charge_energy() const;

 private:
  std::shared_ptr<const EwaldMeshSetup> setup_;
  bool mixed_;
  double seconds_ = 0;  // wall time of the evaluations (add_single_point's not counted: an observation)
  // Made at first use.
  std::unique_ptr<EwaldMesh> double_, single_;
};

}  // namespace vimd
