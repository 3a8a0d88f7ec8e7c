// The pair loops over the cluster-pair list, for the SIMD target being compiled: the kernels of
// every combination of the pair forms of pair_forms.hpp, as templates on the precision. Included by
// nonbonded_kernels_double.cpp and nonbonded_kernels_single.cpp, one per precision (two translation
// units that compile in parallel). A vector holds kJ j atoms of kRows i atoms (PairLayout: a j-cluster
// of 8 atoms is 8 / lanes vectors where a vector is narrower, and two i rows share a vector where it
// is 16 wide); the i-half's force sums stay in registers over the whole half, and each j
// sub-cluster is updated once per list entry. A Highway per-target header: see engine/simd-inl.h.
#if defined(VIMD_FORCEFIELDS_NONBONDED_KERNELS_INL_H_) == defined(HWY_TARGET_TOGGLE)
#ifdef VIMD_FORCEFIELDS_NONBONDED_KERNELS_INL_H_
#undef VIMD_FORCEFIELDS_NONBONDED_KERNELS_INL_H_
#else
#define VIMD_FORCEFIELDS_NONBONDED_KERNELS_INL_H_
#endif

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <tuple>
#include <type_traits>
#include <utility>

#include "forcefields/nonbonded_kernels.hpp"
#include "forcefields/pair_form-inl.h"
#include "forcefields/pair_forms-inl.h"
#include "forcefields/switch_function-inl.h"
#include "hwy/highway.h"

HWY_BEFORE_NAMESPACE();
namespace vimd {
namespace HWY_NAMESPACE {
namespace {

constexpr int kC = NeighborList::kClusterSize;
constexpr int kH = NeighborList::kHalfSize;

template <class... T>
struct TypeList {};
template <class... Lists>
struct ConcatOf {
  using type = TypeList<>;
};
template <class... A>
struct ConcatOf<TypeList<A...>> {
  using type = TypeList<A...>;
};
template <class... A, class... B, class... Rest>
struct ConcatOf<TypeList<A...>, TypeList<B...>, Rest...> {
  using type = typename ConcatOf<TypeList<A..., B...>, Rest...>::type;
};
template <class... Lists>
using Concat = typename ConcatOf<Lists...>::type;

// Whether Form is the configured variant of its pair form.
template <class Form>
bool configured(const PairFormConstants& forms) {
  const auto& constants = std::get<typename Form::Constants>(forms);
  return constants.present() && constants.variant() == Form::kVariant;
}
int present_forms(const PairFormConstants& forms) {
  int n = 0;
  for_each_present_form(forms, [&](const auto&) { ++n; });
  return n;
}

// A combination of pair forms is what one kernel evaluates per pair: Half<Real>, the forms'
// data of an i-half; load(); selected(), whether it is what the configuration asks for;
// energy_force() (g = −φ'/r of the pair, the forms' energies added to e[PairEnergy]) and
// hessian() (a and b of the pair).

// The forms each on their own, summed: the first one sets g (or a and b), the others add to it.
template <class... Form>
struct Sum {
  template <class Real>
  using Half = std::tuple<typename Form::template Half<Real>...>;

  static bool selected(const PairFormConstants& forms) {
    return (configured<Form>(forms) && ...) && present_forms(forms) == static_cast<int>(sizeof...(Form));
  }

  template <class Real>
  static HWY_INLINE void load(const PairViewOf<Real>& d, int ib, Half<Real>& hi) {
    load_each(d, ib, hi, std::index_sequence_for<Form...>{});
  }

  template <bool kEnergies, class Real>
  static HWY_INLINE void energy_force(const PairViewOf<Real>& d, const Half<Real>& hi, int ii, const JBlock<Real>& j,
                                      const PairDistance<Real>& p, SimdMaskOf<Real> inside, SimdVec<Real>& g,
                                      SimdVec<Real>* e) {
    g = SimdVec<Real>::zero();
    add_energy_force<0, kEnergies>(d, hi, ii, j, p, inside, g, e);
  }

  template <class Real>
  static HWY_INLINE void hessian(const PairViewOf<Real>& d, const Half<Real>& hi, int ii, const JBlock<Real>& j,
                                 const PairDistance<Real>& p, SimdVec<Real>& a, SimdVec<Real>& b) {
    a = b = SimdVec<Real>::zero();
    add_hessian<0>(d, hi, ii, j, p, a, b);
  }

 private:
  template <std::size_t I>
  using Nth = std::tuple_element_t<I, std::tuple<Form...>>;

  // Not std::apply: a lambda would lack the target's attributes and stay a call.
  template <class Real, std::size_t... I>
  static HWY_INLINE void load_each(const PairViewOf<Real>& d, int ib, Half<Real>& hi, std::index_sequence<I...>) {
    (std::get<I>(hi).load(d, ib), ...);
  }

  template <std::size_t I, bool kEnergies, class Real>
  static HWY_INLINE void add_energy_force(const PairViewOf<Real>& d, const Half<Real>& hi, int ii,
                                          const JBlock<Real>& j, const PairDistance<Real>& p, SimdMaskOf<Real> inside,
                                          SimdVec<Real>& g, SimdVec<Real>* e) {
    if constexpr (I < sizeof...(Form)) {
      using F = Nth<I>;
      const auto& half = std::get<I>(hi);
      if (half.active(ii)) {
        SimdVec<Real> v;
        if constexpr (I == 0) {
          F::energy_force(d, half, ii, j, p, v, g);
        } else if constexpr (requires { F::add_energy_force(d, half, ii, j, p, v, g); }) {
          F::add_energy_force(d, half, ii, j, p, v, g);
        } else {
          SimdVec<Real> gf;
          F::energy_force(d, half, ii, j, p, v, gf);
          g += gf;
        }
        if constexpr (kEnergies) e[static_cast<int>(F::Constants::kEnergy)] += keep(inside, v);
      }
      add_energy_force<I + 1, kEnergies>(d, hi, ii, j, p, inside, g, e);
    }
  }

  template <std::size_t I, class Real>
  static HWY_INLINE void add_hessian(const PairViewOf<Real>& d, const Half<Real>& hi, int ii, const JBlock<Real>& j,
                                     const PairDistance<Real>& p, SimdVec<Real>& a, SimdVec<Real>& b) {
    if constexpr (I < sizeof...(Form)) {
      using F = Nth<I>;
      const auto& half = std::get<I>(hi);
      if (half.active(ii)) {
        if constexpr (I == 0) {
          F::hessian(d, half, ii, j, p, a, b);
        } else {
          SimdVec<Real> af, bf;
          F::hessian(d, half, ii, j, p, af, bf);
          a += af;
          b += bf;
        }
      }
      add_hessian<I + 1>(d, hi, ii, j, p, a, b);
    }
  }
};

// Two forms potential-switched by the same S (same r_switch and smoothness), e.g. LJ and reaction
// field: S is evaluated once per pair, for both. A and B are the forms' unswitched variants. B
// must act on every row: the Hessian sums start from it.
template <class A, class B>
struct SharedSwitch {
  static_assert(B::template Half<double>::active(0), "SharedSwitch: B must act on every row");
  template <class Real>
  using Half = std::tuple<typename A::template Half<Real>, typename B::template Half<Real>>;

  static bool selected(const PairFormConstants& forms) {
    const auto& a = std::get<typename A::Constants>(forms);
    const auto& b = std::get<typename B::Constants>(forms);
    return a.present() && b.present() && a.potential_switched() && b.potential_switched() &&
           a.potential_switch().r_switch == b.potential_switch().r_switch &&
           a.potential_switch().smoothness == b.potential_switch().smoothness && present_forms(forms) == 2;
  }

  template <class Real>
  static HWY_INLINE void load(const PairViewOf<Real>& d, int ib, Half<Real>& hi) {
    std::get<0>(hi).load(d, ib);
    std::get<1>(hi).load(d, ib);
  }

  template <bool kEnergies, class Real>
  static HWY_INLINE void energy_force(const PairViewOf<Real>& d, const Half<Real>& hi, int ii, const JBlock<Real>& j,
                                      const PairDistance<Real>& p, SimdMaskOf<Real> inside, SimdVec<Real>& g,
                                      SimdVec<Real>* e) {
    using V = SimdVec<Real>;
    const V r = p.r2 * p.rinv;
    V v = V::zero();
    g = V::zero();
    if (std::get<0>(hi).active(ii)) A::energy_force(d, std::get<0>(hi), ii, j, p, v, g);
    V vb, gb, s, ds;
    B::energy_force(d, std::get<1>(hi), ii, j, p, vb, gb);
    switch_value_slope(switch_of(d), r, s, ds);
    apply_switch_factors(s, ds, p.rinv, v, g);
    apply_switch_factors(s, ds, p.rinv, vb, gb);
    if constexpr (kEnergies) {
      e[static_cast<int>(A::Constants::kEnergy)] += keep(inside, v);
      e[static_cast<int>(B::Constants::kEnergy)] += keep(inside, vb);
    }
    g += gb;
  }

  // The coefficients of U = U_A + U_B unswitched, then of U·S.
  template <class Real>
  static HWY_INLINE void hessian(const PairViewOf<Real>& d, const Half<Real>& hi, int ii, const JBlock<Real>& j,
                                 const PairDistance<Real>& p, SimdVec<Real>& a, SimdVec<Real>& b) {
    using V = SimdVec<Real>;
    const V r = p.r2 * p.rinv;
    V u, unused;
    B::hessian(d, std::get<1>(hi), ii, j, p, a, b);
    B::energy_force(d, std::get<1>(hi), ii, j, p, u, unused);
    if (std::get<0>(hi).active(ii)) {
      V a_a, b_a, u_a;
      A::hessian(d, std::get<0>(hi), ii, j, p, a_a, b_a);
      A::energy_force(d, std::get<0>(hi), ii, j, p, u_a, unused);
      a += a_a;
      b += b_a;
      u += u_a;
    }
    apply_switch_hessian(switch_of(d), u, r, p.rinv, a, b);
  }

 private:
  template <class Real>
  static const SwitchFunction& switch_of(const PairViewOf<Real>& d) {
    return std::get<typename A::Constants>(d.forms).potential_switch();
  }
};

// The kernels compiled: every variant of a vdw form, with every variant of a Coulomb form or
// alone; and the shared switch of every pair of switchable vdw and Coulomb forms, which comes
// first: where it applies, it serves instead of the sum of the two switched variants.
template <class Constants, class = std::make_index_sequence<Constants::kVariants.size()>>
struct VariantsOf;
template <class Constants, std::size_t... I>
struct VariantsOf<Constants, std::index_sequence<I...>> {
  using type = TypeList<PairForm<Constants, Constants::kVariants[I]>...>;
};
template <class List>
struct SlotOf;
template <class... Constants>
struct SlotOf<PairFormList<Constants...>> {
  using type = Concat<typename VariantsOf<Constants>::type...>;
};

template <class Vdw, class Coulomb>
struct WithEach;
template <class Vdw, class... Coulomb>
struct WithEach<Vdw, TypeList<Coulomb...>> {
  using type = TypeList<Sum<Vdw, Coulomb>..., Sum<Vdw>>;
};
template <class Vdw, class Coulomb>
struct SumsOf;
template <class... Vdw, class Coulomb>
struct SumsOf<TypeList<Vdw...>, Coulomb> {
  using type = Concat<typename WithEach<Vdw, Coulomb>::type...>;
};

template <class Constants>
concept Switchable = requires { Constants::kUnswitched; };
template <class Vdw, class Coulomb>
struct SharedSwitchOf {
  using type = TypeList<>;
};
template <Switchable Vdw, Switchable Coulomb>
struct SharedSwitchOf<Vdw, Coulomb> {
  using type = TypeList<SharedSwitch<PairForm<Vdw, Vdw::kUnswitched>, PairForm<Coulomb, Coulomb::kUnswitched>>>;
};
template <class Vdw, class CoulombList>
struct SharedSwitchesWith;
template <class Vdw, class... Coulomb>
struct SharedSwitchesWith<Vdw, PairFormList<Coulomb...>> {
  using type = Concat<typename SharedSwitchOf<Vdw, Coulomb>::type...>;
};
template <class VdwList, class CoulombList>
struct SharedSwitches;
template <class... Vdw, class CoulombList>
struct SharedSwitches<PairFormList<Vdw...>, CoulombList> {
  using type = Concat<typename SharedSwitchesWith<Vdw, CoulombList>::type...>;
};

using Combinations =
    Concat<typename SharedSwitches<VdwForms, CoulombForms>::type,
           typename SumsOf<typename SlotOf<VdwForms>::type, typename SlotOf<CoulombForms>::type>::type>;

// The i-half's positions, per vector of rows, moved by −s for the run of its entries with shift s
// (a half's entries come by shift): x_i − (x_j + s) as (x_i − s) − x_j, the shift applied once per
// run, to positions read again from the slot arrays (no unshifted copies held in registers).
template <class Real>
struct ShiftedHalf {
  static constexpr int kVectors = PairLayout<Real>::kRowVectors;
  SimdVec<Real> x[kVectors], y[kVectors], z[kVectors];
  int shift = -1, ib = 0;

  HWY_INLINE void start(int h) {
    ib = h * kH;
    shift = -1;
  }
  HWY_INLINE void follow(const PairPositionsOf<Real>& d, int s) {
    if (s == shift) return;
    shift = s;
    const Vec3& by = d.shifts[s];
    for (int r = 0; r < kVectors; ++r) {
      x[r] = broadcast_rows(d.x + ib, r * PairLayout<Real>::kRows) - by[0];
      y[r] = broadcast_rows(d.y + ib, r * PairLayout<Real>::kRows) - by[1];
      z[r] = broadcast_rows(d.z + ib, r * PairLayout<Real>::kRows) - by[2];
    }
  }
};

// The i-half's atoms, loaded once per half. Keyed on the forms' data, not on the forms: kernels
// whose code is the same (LJ none and potential-shift: the shift is a constant) stay one function.
template <class FormsHalf, class Real>
struct HalfData {
  ShiftedHalf<Real> positions;
  FormsHalf forms;
};
template <class Forms, class Real>
using HalfDataOf = HalfData<typename Forms::template Half<Real>, Real>;

template <class Forms, class Real>
HWY_INLINE void load_half(const PairViewOf<Real>& d, int h, HalfDataOf<Forms, Real>& hi) {
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
template <class Forms, class Real, bool kEnergies, bool kMasks>
void force_halves(const PairViewOf<Real>& view, int h0, int h1, Real* fx, Real* fy, Real* fz, double* half_lj,
                  double* half_coulomb, std::uint32_t* inside_masks) {
  // A local copy: no store in the loop can change it, so the forms' constants are read before it.
  const PairViewOf<Real> d = view;
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
          const PairDistance<Real> p{r2s, rinv, rinv * rinv};
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
template <class Forms, class Real>
void hessian_halves(const PairViewOf<Real>& view, const Real* ux, const Real* uy, const Real* uz,
                    const std::uint32_t* masks, int h0, int h1, Real* ox, Real* oy, Real* oz) {
  const PairViewOf<Real> d = view;  // as in force_halves
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
          const PairDistance<Real> p{r2s, rinv, rinv * rinv};
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

// The bits of an entry's pairs within the range at the positions (every listed pair is looked at).
template <class Real>
HWY_INLINE std::uint32_t entry_inside_bits(const PairPositionsOf<Real>& d, ShiftedHalf<Real>& positions,
                                           NeighborList::Entry entry, SimdVec<Real> range2) {
  using V = SimdVec<Real>;
  constexpr int kRows = PairLayout<Real>::kRows, kJ = PairLayout<Real>::kJLanes;
  positions.follow(d, entry.shift());
  std::uint32_t inside_bits = 0;
  for (int js = 0; js < kC; js += kJ) {
    const int jb = entry.j_cluster() * kC + js;
    const V xj = load_j(d.x + jb), yj = load_j(d.y + jb), zj = load_j(d.z + jb);
    // Every lane, listed or not (padding and excluded pairs have finite distances too); the
    // entry's mask then keeps the listed pairs: cheaper than a vector mask per row.
    for (int ii = 0; ii < kH; ii += kRows) {
      const V dx = xj - positions.x[ii / kRows], dy = yj - positions.y[ii / kRows], dz = zj - positions.z[ii / kRows];
      inside_bits |= bits_from_mask(dx * dx + dy * dy + dz * dz < range2) << (ii * kC + js);
    }
  }
  return inside_bits & entry.mask;
}

// For each 8-bit lane mask, the lanes it sets in order, 4 bits each (lane 0 in the lowest nibble).
constexpr std::array<std::uint32_t, 256> kSetLanes = [] {
  std::array<std::uint32_t, 256> table{};
  for (unsigned bits = 0; bits < 256; ++bits)
    for (unsigned lane = 0, n = 0; lane < 8; ++lane)
      if (bits & (1u << lane)) table[bits] |= lane << (4 * n++);
  return table;
}();

// Stores the lanes of `values` that `keep` selects to out, in order; returns how many. Writes a
// whole vector at out. Highway's CompressStore does this where the target has it as an
// instruction (AVX-512); its AVX2 version declares its index table as a local constexpr array,
// which GCC copies to the stack (1 KiB) at every call, so up to 8 lanes take kSetLanes instead.
template <class D>
HWY_INLINE int compress_store(D d, hn::Vec<D> values, hn::Mask<D> keep, hn::TFromD<D>* out) {
  if constexpr (hn::MaxLanes(D()) <= 8 && sizeof(hn::TFromD<D>) == 4) {
    const hn::RebindToUnsigned<D> du;
    std::uint8_t byte[8] = {};
    hn::StoreMaskBits(d, keep, byte);
    const auto lanes = hn::And(hn::Shr(hn::Set(du, kSetLanes[byte[0]]), hn::ShiftLeft<2>(hn::Iota(du, 0))),
                               hn::Set(du, 15));
    hn::StoreU(hn::TableLookupLanes(values, hn::IndicesFromVec(d, hn::BitCast(hn::RebindToSigned<D>(), lanes))), d,
               out);
    return static_cast<int>(hwy::PopCount(byte[0]));
  } else {
    return static_cast<int>(hn::CompressStore(values, keep, d, out));
  }
}

// keep(h, k, entry, bits) for the entries of halves [h0, h1) that may have a listed pair inside the
// range, in order: k the entry's place in its half, bits those pairs; then half_done(h). Entries
// that the view's half_skip and cluster_moved put beyond the range are passed over unseen (their
// bits would be 0).
template <class Real, class Keep, class HalfDone>
HWY_INLINE void inside_bits_of_halves(const PairPositionsOf<Real>& d, int h0, int h1, Keep&& keep,
                                      HalfDone&& half_done) {
  using V = SimdVec<Real>;
  const V range2 = V::broadcast(d.cutoff2);
  const hn::CappedTag<float, 16> df;
  const hn::Rebind<std::int32_t, decltype(df)> di;
  const hn::Rebind<std::uint32_t, decltype(df)> du;
  const hn::Rebind<NeighborList::NearestDistance, decltype(df)> dn;
  const auto unit = hn::Set(df, NeighborList::kNearestUnit);
  const auto lane_index = hn::Iota(di, 0);  // not Iota(di, k): its lanes would be stored one by one
  const int lanes = static_cast<int>(hn::Lanes(df));
  static_assert(sizeof(NeighborList::Entry) == 2 * sizeof(std::uint32_t), "Entry: two words");
  constexpr int kBlock = 256;
  HWY_ALIGN std::int32_t look[kBlock];  // a vector's compressed store stays below its own end
  for (int h = h0; h < h1; ++h) {
    ShiftedHalf<Real> positions;
    positions.start(h);
    const int count = d.half_start[h + 1] - d.half_start[h];
    const NeighborList::Entry* entries = entries_of_half(d, h);
    const NeighborList::NearestDistance* nearest = d.half_nearest ? d.half_nearest[h] : nullptr;
    if (!nearest) {
      for (int k = 0; k < count; ++k) keep(h, k, entries[k], entry_inside_bits(d, positions, entries[k], range2));
      half_done(h);
      continue;
    }
    const float half_skip = d.half_skip[h];
    // Which entries are nearer than their skip distance is unpredictable: they are listed first,
    // by vectors, as a branch per entry would cost more than the look itself.
    for (int k0 = 0; k0 < count; k0 += kBlock) {
      const int n = std::min(kBlock, count - k0);
      int m = 0, k = 0;
      for (; k + lanes <= n; k += lanes) {
        hn::Vec<decltype(du)> cluster_and_shift, mask;
        hn::LoadInterleaved2(du, reinterpret_cast<const std::uint32_t*>(entries + k0 + k), cluster_and_shift, mask);
        const auto j_cluster = hn::BitCast(di, hn::ShiftRight<NeighborList::Entry::kShiftBits>(cluster_and_shift));
        const auto skip = hn::Add(hn::Set(df, half_skip), hn::GatherIndex(df, d.cluster_moved, j_cluster));
        const auto units = hn::BitCast(di, hn::PromoteTo(du, hn::LoadU(dn, nearest + k0 + k)));
        const auto near = hn::Lt(hn::Mul(hn::ConvertTo(df, units), unit), skip);
        m += compress_store(di, hn::Add(lane_index, hn::Set(di, k0 + k)), hn::RebindMask(di, near), look + m);
      }
      for (; k < n; ++k) {
        look[m] = k0 + k;
        m += nearest[k0 + k] * NeighborList::kNearestUnit < half_skip + d.cluster_moved[entries[k0 + k].j_cluster()];
      }
      for (int t = 0; t < m; ++t) {
        const NeighborList::Entry& entry = entries[look[t]];
        keep(h, look[t], entry, entry_inside_bits(d, positions, entry, range2));
      }
    }
    half_done(h);
  }
}

template <class Real>
void mask_halves(const PairPositionsOf<Real>& d, int h0, int h1, std::uint32_t* inside_masks) {
  // Without nearest distances every entry is looked at, and written below.
  if (d.half_nearest) std::fill(inside_masks + d.half_start[h0], inside_masks + d.half_start[h1], 0u);
  inside_bits_of_halves(
      d, h0, h1,
      [&](int h, int k, const NeighborList::Entry&, std::uint32_t bits) { inside_masks[d.half_start[h] + k] = bits; },
      [](int) {});
}

template <class Real>
int narrow_halves(const PairPositionsOf<Real>& d, int h0, int h1, NeighborList::Entry* kept, int* kept_of_half) {
  int n = 0, before = 0;
  // Without a branch (which entries stay is unpredictable): every entry looked at is written, and
  // the next one overwrites it unless it stays.
  inside_bits_of_halves(
      d, h0, h1,
      [&](int, int, const NeighborList::Entry& entry, std::uint32_t bits) {
        kept[n] = entry;
        kept[n].mask = bits;
        n += bits != 0;
      },
      [&](int h) {
        kept_of_half[h - h0] = n - before;
        before = n;
      });
  return n;
}

// Lane k: values[index_k] in double precision, for the lanes of SimdDouble.
template <class Real>
HWY_INLINE SimdDouble gather_double(const Real* values, hn::Vec<hn::Rebind<std::int32_t, SimdTag>> index) {
  const SimdTag dd;
  if constexpr (std::is_same_v<Real, float>)
    return {hn::PromoteTo(dd, hn::GatherIndex(hn::Rebind<float, SimdTag>(), values, index))};
  else
    return {hn::GatherIndex(dd, values, hn::PromoteTo(hn::Rebind<std::int64_t, SimdTag>(), index))};
}

// ExcludedKernelOf for one form: pairs in vectors of doubles, their forces added one pair at a
// time (an atom is in several pairs of a vector).
template <class Form, class Real>
HWY_INLINE void form_excluded_pairs(const Form& form, const PairViewOf<Real>& d, const NeighborList::ExcludedPair* pairs,
                                    double cutoff2, int p0, int p1, Real* fx, Real* fy, Real* fz, double* energies) {
  using V = SimdDouble;
  using Pair = NeighborList::ExcludedPair;
  static_assert(sizeof(Pair) == 3 * sizeof(std::int32_t), "ExcludedPair: three packed ints");
  constexpr int kMaxLanes = HWY_MAX_BYTES / sizeof(double);
  const hn::Rebind<std::int32_t, SimdTag> di;
  const int lanes = V::lanes();
  const double* shifts = d.shifts[0].data();
  HWY_ALIGN double x[kMaxLanes], y[kMaxLanes], z[kMaxLanes];
  V energy = V::zero();
  for (int p = p0; p < p1; p += lanes) {
    const int n = std::min(lanes, p1 - p);
    const Pair* batch = pairs + p;
    Pair padded[kMaxLanes];
    if (n < lanes) {  // lanes past n repeat the last pair, masked below
      for (int k = 0; k < lanes; ++k) padded[k] = pairs[p + std::min(k, n - 1)];
      batch = padded;
    }
    hn::Vec<decltype(di)> i, j, shift;
    hn::LoadInterleaved3(di, reinterpret_cast<const std::int32_t*>(batch), i, j, shift);
    shift = hn::Mul(shift, hn::Set(di, 3));
    const V dx = gather_double(d.x, i) - gather_double(d.x, j) - gather_double(shifts, shift);
    const V dy = gather_double(d.y, i) - gather_double(d.y, j) - gather_double(shifts + 1, shift);
    const V dz = gather_double(d.z, i) - gather_double(d.z, j) - gather_double(shifts + 2, shift);
    const V r2 = dx * dx + dy * dy + dz * dz;
    const SimdMask inside = mask_from_bits<double>((1u << n) - 1) & (r2 < cutoff2);
    V v, g;
    excluded_energy_force(form, gather_double(d.charge, i) * gather_double(d.charge, j),
                          select(inside, r2, V::broadcast(1.0)), v, g);
    energy += keep(inside, v);
    g = keep(inside, g);
    simd_store(x, g * dx);
    simd_store(y, g * dy);
    simd_store(z, g * dz);
    for (int k = 0; k < n; ++k) {
      const int a = batch[k].i_slot, b = batch[k].j_slot;
      fx[a] += x[k];
      fy[a] += y[k];
      fz[a] += z[k];
      fx[b] -= x[k];
      fy[b] -= y[k];
      fz[b] -= z[k];
    }
  }
  energies[static_cast<int>(Form::kEnergy)] += simd_sum(energy);
}

// ExcludedKernelOf: every present form with excluded pairs (PairFormConstants' I-th onwards).
template <class Real, std::size_t I = 0>
void excluded_pairs(const PairViewOf<Real>& d, const NeighborList::ExcludedPair* pairs, double cutoff2, int p0, int p1,
                    Real* fx, Real* fy, Real* fz, double* energies) {
  if constexpr (I < std::tuple_size_v<PairFormConstants>) {
    using Form = std::tuple_element_t<I, PairFormConstants>;
    if constexpr (kHasExcludedPairs<Form>) {
      const Form& form = std::get<I>(d.forms);
      if (form.present()) form_excluded_pairs(form, d, pairs, cutoff2, p0, p1, fx, fy, fz, energies);
    }
    excluded_pairs<Real, I + 1>(d, pairs, cutoff2, p0, p1, fx, fy, fz, energies);
  }
}

template <class Real>
using ForceKernelOf = void (*)(const PairViewOf<Real>&, int, int, Real*, Real*, Real*, double*, double*,
                               std::uint32_t*);
template <class Real>
using HessianKernelOf = void (*)(const PairViewOf<Real>&, const Real*, const Real*, const Real*, const std::uint32_t*,
                                 int, int, Real*, Real*, Real*);

// The kernel of the first selected combination (null if none is).
template <class Real, bool kEnergies, bool kMasks, class... Forms>
ForceKernelOf<Real> force_kernel_among(const PairFormConstants& forms, TypeList<Forms...>) {
  ForceKernelOf<Real> kernel = nullptr;
  (void)((Forms::selected(forms) && (kernel = force_halves<Forms, Real, kEnergies, kMasks>, true)) || ...);
  return kernel;
}
// Energies are rare (sampled steps): their kernel keeps masks where given.
template <class Real>
ForceKernelOf<Real> force_kernel_for(const PairFormConstants& forms, bool energies, bool masks) {
  if (energies) return force_kernel_among<Real, true, true>(forms, Combinations{});
  return masks ? force_kernel_among<Real, false, true>(forms, Combinations{})
               : force_kernel_among<Real, false, false>(forms, Combinations{});
}
template <class Real, class... Forms>
HessianKernelOf<Real> hessian_kernel_among(const PairFormConstants& forms, TypeList<Forms...>) {
  HessianKernelOf<Real> kernel = nullptr;
  (void)((Forms::selected(forms) && (kernel = hessian_halves<Forms, Real>, true)) || ...);
  return kernel;
}

}  // namespace

}  // namespace HWY_NAMESPACE
}  // namespace vimd
HWY_AFTER_NAMESPACE();

#endif  // VIMD_FORCEFIELDS_NONBONDED_KERNELS_INL_H_
