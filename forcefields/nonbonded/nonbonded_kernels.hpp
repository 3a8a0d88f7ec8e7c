#pragma once
// The nonbonded pair kernels behind NonbondedPairTerm, compiled for every SIMD target Highway
// supports on x86 (SSE4, AVX2, AVX-512) and chosen at run time for the CPU the program runs on
// (kernel_combinations-inl.h, pruning-inl.h, excluded_pairs-inl.h). Nothing here depends on the target: the view is plain arrays, the
// kernels are plain function pointers.
#include <cstddef>
#include <cstdint>
#include <stdexcept>

#include "forcefields/nonbonded/neighbor_list.hpp"
#include "forcefields/nonbonded/pair_forms.hpp"

namespace vimd {

// What the mask kernels read: positions in slot order, a list and its range (cutoff2, nm²).
// Real: double, or float for the single-precision kernels.
template <class Real>
struct PairPositionsOf {
  const Real *x, *y, *z;
  const NeighborList::Entry* entries;
  const int* half_start;
  const Vec3* shifts;
  double cutoff2;
  // Where given (a searched list, NeighborList::point_to_halves; a list narrowed from one, kept in
  // each thread's part): half h's entries begin at half_entries[h], not entries + half_start[h].
  // Only a searched list has nearest distances (NeighborList::NearestDistance); they begin at
  // half_nearest[h].
  const NeighborList::Entry* const* half_entries = nullptr;
  const NeighborList::NearestDistance* const* half_nearest = nullptr;
  // With half_nearest: an entry of half h and j-cluster c whose nearest distance is at least
  // half_skip[h] + cluster_moved[c] (nm, rounded up, so that their float sum is too) is known to
  // have no pair inside the range, unseen.
  const float* half_skip = nullptr;
  const float* cluster_moved = nullptr;
};

// Half h's entries: at half_entries[h] where given (a list kept in parts), else in `entries`.
template <class Real>
inline const NeighborList::Entry* entries_of_half(const PairPositionsOf<Real>& d, int h) {
  return d.half_entries ? d.half_entries[h] : d.entries + d.half_start[h];
}

// Everything the pair loops read: the atoms' parameters as plain pointers, and the constants of
// the pair forms. Positions and charges are in slot order; the LJ parameters of type t with the
// atoms of j-cluster c are lj[lj_index(t, c)]: its kClusterSize c6 values, then as many c12, in slot
// order, so that an i atom's parameters with a j-cluster are one cache line.
template <class Real, class FormSet = PairFormConstants>
struct PairViewOf : PairPositionsOf<Real> {
  const Real* charge;
  const int* type;
  const Real* lj;
  const unsigned char* type_has_lj;  // per type: 1 if its c6 or c12 with some type is not zero
  std::size_t n_slots;
  FormSet forms;  // the constants of every form the kernels may evaluate
};
using PairView = PairViewOf<double>;
// Where PairViewOf::lj holds the parameters of type t with j-cluster c.
inline std::size_t lj_index(int type, int j_cluster, std::size_t n_slots) {
  return 2 * (static_cast<std::size_t>(type) * n_slots + static_cast<std::size_t>(j_cluster) * NeighborList::kClusterSize);
}

// Forces of the i-halves [h0, h1) into the SoA buffer (fx, fy, fz); the energies of half h into
// half_lj[h] (PairEnergy::vdw), half_coulomb[h] (PairEnergy::coulomb), so that their total can be summed in an order that does not depend
// on the thread count (a kernel without energies leaves them untouched). A pair counts if its
// entry's mask lists it and it is inside the view's cut-off. If inside_masks is not null,
// inside_masks[e] receives the bits of entry e's pairs that counted.
using ForceKernel = void (*)(const PairView&, int h0, int h1, double* fx, double* fy, double* fz, double* half_lj,
                             double* half_coulomb, std::uint32_t* inside_masks);
// The same in single precision: pairs computed and forces accumulated in single precision (the
// energies of a half summed in double), as GROMACS's default build does; about twice the pairs
// per vector. For dynamics that tolerate force errors of ~1e-6 relative (RATTLE, SHAKE, Verlet:
// precision = "mixed"), and for the variational solve's first iteration of a step, whose error
// the double-precision iterations after it correct.
using SingleForceKernel = void (*)(const PairViewOf<float>&, int h0, int h1, float* fx, float* fy, float* fz,
                                   double* half_lj, double* half_coulomb, std::uint32_t* inside_masks);
// inside_masks[e] = the bits of entry e's listed pairs that are inside the cut-off, for [h0, h1);
// 0 without a look at its atoms for an entry the view's half_skip and cluster_moved put beyond it.
using MaskKernel = void (*)(const PairPositionsOf<double>&, int h0, int h1, std::uint32_t* inside_masks);
// The same on single-precision positions (twice the pairs per vector); its rounding is the
// caller's to cover, with a cut-off a little beyond the range it needs.
using SingleMaskKernel = void (*)(const PairPositionsOf<float>&, int h0, int h1, std::uint32_t* inside_masks);
// The entries of [h0, h1) with a pair inside the cut-off, their masks cut to those pairs, into
// kept (room for all of the halves' entries) in order; kept_of_half[h − h0]: how many of half h's.
// Returns how many in all.
using NarrowKernel = int (*)(const PairPositionsOf<double>&, int h0, int h1, NeighborList::Entry* kept,
                             int* kept_of_half);
using SingleNarrowKernel = int (*)(const PairPositionsOf<float>&, int h0, int h1, NeighborList::Entry* kept,
                                   int* kept_of_half);
// (∇²V u) of the i-halves [h0, h1) into (ox, oy, oz), over the pairs masks[e] selects in entry e:
// those that interact (inside masks of a force or mask pass); the kernel does not test the cut-off.
using HessianKernel = void (*)(const PairView&, const double* ux, const double* uy, const double* uz,
                               const std::uint32_t* masks, int h0, int h1, double* ox, double* oy, double* oz);
// The same in single precision, for the variational integrator's mixed-precision solve.
using SingleHessianKernel = void (*)(const PairViewOf<float>&, const float* ux, const float* uy, const float* uz,
                                     const std::uint32_t* masks, int h0, int h1, float* ox, float* oy, float* oz);

// The excluded pairs [p0, p1) of a list: what the configured forms still count of those inside the
// cut-off (reaction field: k_rf r² − c_rf; Ewald: −erf(βr)/r), in double precision from the
// view's positions, added to force buffers of the view's precision; their energies are added to
// energies[PairEnergy].
template <class Real>
using ExcludedKernelOf = void (*)(const PairViewOf<Real>&, const NeighborList::ExcludedPair* pairs, double cutoff2,
                                  int p0, int p1, Real* fx, Real* fy, Real* fz, double* energies);

namespace simd {

// The kernels of the pair forms `forms` configures (their variants, and one switch for the vdw
// and Coulomb forms where both potential-switch alike). energies: false for forces only. masks:
// the force kernel records inside_masks where given (a kernel chosen without may ignore them).
ForceKernel force_kernel(const PairFormConstants& forms, bool energies, bool masks);
SingleForceKernel single_force_kernel(const PairFormConstants& forms, bool energies, bool masks);
MaskKernel mask_kernel();
SingleMaskKernel single_mask_kernel();
NarrowKernel narrow_kernel();
SingleNarrowKernel single_narrow_kernel();
HessianKernel hessian_kernel(const PairFormConstants& forms);
SingleHessianKernel single_hessian_kernel(const PairFormConstants& forms);
ExcludedKernelOf<double> excluded_kernel();
ExcludedKernelOf<float> single_excluded_kernel();

// The kernel dispatch found, which is null only for constants no configuration makes (no vdw form,
// or several forms of a slot).
template <class Kernel>
Kernel checked_kernel(Kernel kernel) {
  if (!kernel) throw std::logic_error("no pair kernel for this combination of pair forms");
  return kernel;
}

}  // namespace simd
}  // namespace vimd
