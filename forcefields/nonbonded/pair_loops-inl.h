// The pair loops over the cluster-pair list, for the SIMD target being compiled: forces (with
// energies and inside-cut-off masks where asked) and Hessian–vector products, as templates on a
// combination of pair forms (kernel_combinations-inl.h) and on the precision. A vector holds kJ j
// atoms of kRows i atoms (PairLayout: a j-cluster of 8 atoms is 8 / lanes vectors where a vector is
// narrower, and two i rows share a vector where it is 16 wide); the i-half's force sums stay in
// registers over the whole half, and each j sub-cluster is updated once per list entry. A Highway
// per-target header: see simd/simd-inl.h.
#if defined(VIMD_FORCEFIELDS_NONBONDED_PAIR_LOOPS_INL_H_) == defined(HWY_TARGET_TOGGLE)
#ifdef VIMD_FORCEFIELDS_NONBONDED_PAIR_LOOPS_INL_H_
#undef VIMD_FORCEFIELDS_NONBONDED_PAIR_LOOPS_INL_H_
#else
#define VIMD_FORCEFIELDS_NONBONDED_PAIR_LOOPS_INL_H_
#endif

#include <cstdint>

#include "forcefields/nonbonded/nonbonded_kernels.hpp"
#include "forcefields/nonbonded/pair_form-inl.h"
#include "forcefields/nonbonded/pair_layout-inl.h"
#include "hwy/highway.h"
#include "simd/simd-inl.h"

HWY_BEFORE_NAMESPACE();
namespace vimd {
namespace HWY_NAMESPACE {
namespace {

// The i-half's atoms, loaded once per half. Keyed on the forms' data, not on the forms: kernels
// whose code is the same (LJ none and potential-shift: the shift is a constant) stay one function.
template <class FormsHalf, class Real>
struct HalfData {
  ShiftedHalf<Real> positions;
  FormsHalf forms;
};
template <class Forms, class Real>
using HalfDataOf = HalfData<typename Forms::template Half<Real>, Real>;

template <class Forms, class Real, class FormSet>
HWY_INLINE void load_half(const PairViewOf<Real, FormSet>& d, int h, HalfDataOf<Forms, Real>& hi) {
  hi.positions.start(h);
  Forms::load(d, h * kH, hi.forms);
}

// The least r² of the pair loops' arithmetic (GROMACS's floor in single precision; r⁻¹² still fits
// a float): the lanes the masks drop (r = 0 on the diagonal) stay finite for one max instead of a
// blend per vector. Their results are discarded; a listed pair closer than 0.6 pm would be clamped,
// as in GROMACS.
constexpr double kPairR2Floor[] = {3.82e-7};  // nm²

// A pair's term t, computed from x_j − x_i, taken from row i's sums and added to j's.
template <class V>
HWY_INLINE void take_pair_term(V& ix, V& iy, V& iz, V& jx, V& jy, V& jz, V tx, V ty, V tz) {
  ix -= tx;
  iy -= ty;
  iz -= tz;
  jx += tx;
  jy += ty;
  jz += tz;
}

// Forms: a combination of pair forms (Sum, SharedSwitch). Real: the precision of the pair
// arithmetic and of the force sums (float: the single-precision kernel). kEnergies: also the
// energies (without them, half_lj and half_coulomb are not touched). kMasks: also the inside
// masks, where inside_masks is given (without, it is ignored: a test per row would slow the loop).
template <class Forms, class Real, bool kEnergies, bool kMasks, class FormSet>
void force_halves(const PairViewOf<Real, FormSet>& view, int h0, int h1, Real* fx, Real* fy, Real* fz, double* half_lj,
                  double* half_coulomb, std::uint32_t* inside_masks) {
  // A local copy: no store in the loop can change it, so the forms' constants are read before it.
  const PairViewOf<Real, FormSet> d = view;
  using V = SimdVec<Real>;
  using Mask = SimdMaskOf<Real>;
  constexpr int kRows = PairLayout<Real>::kRows, kJ = PairLayout<Real>::kJLanes;
  constexpr int kRowVectors = PairLayout<Real>::kRowVectors;
  const V zero = V::zero(), cutoff2 = V::broadcast(d.cutoff2), r2_floor = splat<kPairR2Floor>(0, zero);
  ListedLanes<Real> listed;
  for (int h = h0; h < h1; ++h) {
    const int e0 = d.half_start[h], e1 = d.half_start[h + 1];
    if constexpr (kEnergies) half_lj[h] = half_coulomb[h] = 0;
    if (e0 == e1) continue;
    const NeighborList::Entry* entries = entries_of_half(d, h);
    HalfDataOf<Forms, Real> hi;
    load_half<Forms>(d, h, hi);
    V fxi[kRowVectors], fyi[kRowVectors], fzi[kRowVectors];
    for (int r = 0; r < kRowVectors; ++r) fxi[r] = fyi[r] = fzi[r] = zero;
    V energy[kPairEnergies];
    for (V& e : energy) e = zero;
    for (int e = e0; e < e1; ++e) {
      const NeighborList::Entry entry = entries[e - e0];
      hi.positions.follow(d, entry.shift());
      listed.start(entry.mask);
      std::uint32_t inside_bits = 0;
      for (int js = 0; js < kC; js += kJ) {
        const int jb = entry.j_cluster() * kC + js;
        const V xj = load_j(d.x + jb), yj = load_j(d.y + jb), zj = load_j(d.z + jb);
        const JBlock<Real> j{jb, load_j(d.charge + jb)};
        V fxj = zero, fyj = zero, fzj = zero;
#pragma GCC unroll 4  // the i sums are registers only if their index is a constant
        for (int ii = 0; ii < kH; ii += kRows) {
          if (listed.bits(ii, js) == 0) continue;
          // x_j − x_i, not x_i − x_j: the i positions are then the operand that x86 can read from
          // memory, where the i rows do not all fit in registers (AVX2's 16).
          const V dx = xj - hi.positions.x[ii / kRows], dy = yj - hi.positions.y[ii / kRows],
                  dz = zj - hi.positions.z[ii / kRows];
          const V r2 = dx * dx + dy * dy + dz * dz;
          const Mask inside = listed.of(ii, js) & (r2 < cutoff2);
          if (kMasks && inside_masks) inside_bits |= bits_from_mask(inside) << (ii * kC + js);
          const V r2s = simd_max(r2, r2_floor);
          const V rinv = simd_rsqrt(r2s);
          const PairDistance<V> p{r2s, rinv, rinv * rinv};
          V g;
          Forms::template energy_force<kEnergies>(d, hi.forms, ii, j, p, inside, g, energy);
          g = keep(inside, g);
          const V gx = g * dx, gy = g * dy, gz = g * dz;
          take_pair_term(fxi[ii / kRows], fyi[ii / kRows], fzi[ii / kRows], fxj, fyj, fzj, gx, gy, gz);
        }
        add_j(fx + jb, fxj);
        add_j(fy + jb, fyj);
        add_j(fz + jb, fzj);
      }
      if (kMasks && inside_masks) inside_masks[e] = inside_bits;
    }
    const int ib = h * kH;
    for (int ii = 0; ii < kH; ii += kRows) {
      add_row_sums(fx + ib, ii, fxi[ii / kRows]);
      add_row_sums(fy + ib, ii, fyi[ii / kRows]);
      add_row_sums(fz + ib, ii, fzi[ii / kRows]);
    }
    if constexpr (kEnergies) {
      half_lj[h] = simd_sum(energy[static_cast<int>(PairEnergy::vdw)]);
      half_coulomb[h] = simd_sum(energy[static_cast<int>(PairEnergy::coulomb)]);
    }
  }
}

// Per pair a u_ij + b (d·u_ij) d, for exactly the pairs the masks select (no cut-off test here).
// Forms, Real: as in force_halves.
template <class Forms, class Real, class FormSet>
void hessian_halves(const PairViewOf<Real, FormSet>& view, const Real* ux, const Real* uy, const Real* uz,
                    const std::uint32_t* masks, int h0, int h1, Real* ox, Real* oy, Real* oz) {
  const PairViewOf<Real, FormSet> d = view;  // as in force_halves
  using V = SimdVec<Real>;
  using Mask = SimdMaskOf<Real>;
  constexpr int kRows = PairLayout<Real>::kRows, kJ = PairLayout<Real>::kJLanes;
  constexpr int kRowVectors = PairLayout<Real>::kRowVectors;
  const V zero = V::zero(), r2_floor = splat<kPairR2Floor>(0, zero);
  ListedLanes<Real> listed;
  for (int h = h0; h < h1; ++h) {
    const int e0 = d.half_start[h], e1 = d.half_start[h + 1];
    if (e0 == e1) continue;
    const NeighborList::Entry* entries = entries_of_half(d, h);
    HalfDataOf<Forms, Real> hi;
    load_half<Forms>(d, h, hi);
    const int ib = h * kH;
    Real uxi[kH], uyi[kH], uzi[kH];
    for (int ii = 0; ii < kH; ++ii) {
      uxi[ii] = ux[ib + ii];
      uyi[ii] = uy[ib + ii];
      uzi[ii] = uz[ib + ii];
    }
    V oxi[kRowVectors], oyi[kRowVectors], ozi[kRowVectors];
    for (int r = 0; r < kRowVectors; ++r) oxi[r] = oyi[r] = ozi[r] = zero;
    for (int e = e0; e < e1; ++e) {
      const NeighborList::Entry entry = entries[e - e0];
      hi.positions.follow(d, entry.shift());
      listed.start(masks[e]);
      for (int js = 0; js < kC; js += kJ) {
        const int jb = entry.j_cluster() * kC + js;
        const V xj = load_j(d.x + jb), yj = load_j(d.y + jb), zj = load_j(d.z + jb);
        const JBlock<Real> j{jb, load_j(d.charge + jb)};
        const V uxj = load_j(ux + jb), uyj = load_j(uy + jb), uzj = load_j(uz + jb);
        V oxj = zero, oyj = zero, ozj = zero;
#pragma GCC unroll 4  // the i sums are registers only if their index is a constant
        for (int ii = 0; ii < kH; ii += kRows) {
          if (listed.bits(ii, js) == 0) continue;
          // x_j − x_i and u_j − u_i, as in force_halves.
          const V dx = xj - hi.positions.x[ii / kRows], dy = yj - hi.positions.y[ii / kRows],
                  dz = zj - hi.positions.z[ii / kRows];
          const V r2 = dx * dx + dy * dy + dz * dz;
          const Mask inside = listed.of(ii, js);
          const V r2s = simd_max(r2, r2_floor);
          const V rinv = simd_rsqrt(r2s);
          const PairDistance<V> p{r2s, rinv, rinv * rinv};
          V a, b;
          Forms::hessian(d, hi.forms, ii, j, p, a, b);
          a = keep(inside, a);
          b = keep(inside, b);
          const V dux = uxj - broadcast_rows(uxi, ii), duy = uyj - broadcast_rows(uyi, ii),
                  duz = uzj - broadcast_rows(uzi, ii);
          const V bp = b * (dx * dux + dy * duy + dz * duz);
          const V hx = a * dux + bp * dx, hy = a * duy + bp * dy, hz = a * duz + bp * dz;
          take_pair_term(oxi[ii / kRows], oyi[ii / kRows], ozi[ii / kRows], oxj, oyj, ozj, hx, hy, hz);
        }
        add_j(ox + jb, oxj);
        add_j(oy + jb, oyj);
        add_j(oz + jb, ozj);
      }
    }
    for (int ii = 0; ii < kH; ii += kRows) {
      add_row_sums(ox + ib, ii, oxi[ii / kRows]);
      add_row_sums(oy + ib, ii, oyi[ii / kRows]);
      add_row_sums(oz + ib, ii, ozi[ii / kRows]);
    }
  }
}

}  // namespace
}  // namespace HWY_NAMESPACE
}  // namespace vimd
HWY_AFTER_NAMESPACE();

#endif  // VIMD_FORCEFIELDS_NONBONDED_PAIR_LOOPS_INL_H_
