// Which kernels are compiled and which one a configuration runs, for the SIMD target being
// compiled: every combination of the pair forms of pair_forms.hpp (their variants summed, or two
// switched forms sharing one switch), each instantiating the pair loops of pair_loops-inl.h. A
// Highway per-target header: see simd/simd-inl.h.
#if defined(VIMD_FORCEFIELDS_NONBONDED_KERNEL_COMBINATIONS_INL_H_) == defined(HWY_TARGET_TOGGLE)
#ifdef VIMD_FORCEFIELDS_NONBONDED_KERNEL_COMBINATIONS_INL_H_
#undef VIMD_FORCEFIELDS_NONBONDED_KERNEL_COMBINATIONS_INL_H_
#else
#define VIMD_FORCEFIELDS_NONBONDED_KERNEL_COMBINATIONS_INL_H_
#endif

#include <cstddef>
#include <cstdint>
#include <tuple>
#include <type_traits>
#include <utility>

#include "forcefields/nonbonded/nonbonded_kernels.hpp"
#include "forcefields/nonbonded/pair_form-inl.h"
#include "forcefields/nonbonded/pair_forms-inl.h"
#include "forcefields/nonbonded/pair_loops-inl.h"
#include "forcefields/nonbonded/switch_function-inl.h"
#include "hwy/highway.h"
#include "simd/simd-inl.h"

HWY_BEFORE_NAMESPACE();
namespace vimd {
namespace HWY_NAMESPACE {
namespace {

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

template <class Form, class Real, class FormSet>
HWY_INLINE const ConstantsOf<Form>& constants_of(const PairViewOf<Real, FormSet>& d) {
  return std::get<ConstantsOf<Form>>(d.forms);
}

// Whether Form is the configured variant of its pair form.
template <class Form>
bool configured(const PairFormConstants& forms) {
  const auto& constants = std::get<ConstantsOf<Form>>(forms);
  return constants.present() && constants.variant() == FormOf<Form>::kVariant;
}
int present_forms(const PairFormConstants& forms) {
  int n = 0;
  for_each_present_form(forms, [&](const auto&) { ++n; });
  return n;
}

// A combination of pair forms is what one kernel evaluates per pair: Half<Real>, the rows of the
// forms' parameters (PairRows) of an i-half; load(); selected(), whether it is what the
// configuration asks for;
// energy_force() (g = −φ'/r of the pair, the forms' energies added to e[PairEnergy]) and
// hessian() (a and b of the pair).

// The forms each on their own, summed: the first one sets g (or a and b), the others add to it.
template <class... Form>
struct Sum {
  template <class Real>
  using Half = std::tuple<PairRowsOf<Form, Real>...>;

  static bool selected(const PairFormConstants& forms) {
    return (configured<Form>(forms) && ...) && present_forms(forms) == static_cast<int>(sizeof...(Form));
  }

  template <class Real, class FormSet>
  static HWY_INLINE void load(const PairViewOf<Real, FormSet>& d, int ib, Half<Real>& hi) {
    load_each(d, ib, hi, std::index_sequence_for<Form...>{});
  }

  template <bool kEnergies, class Real, class FormSet>
  static HWY_INLINE void energy_force(const PairViewOf<Real, FormSet>& d, const Half<Real>& hi, int ii, const JBlock<Real>& j,
                                      const PairDistance<SimdVec<Real>>& p, SimdMaskOf<Real> inside, SimdVec<Real>& g,
                                      SimdVec<Real>* e) {
    g = SimdVec<Real>::zero();
    add_energy_force<0, kEnergies>(d, hi, ii, j, p, inside, g, e);
  }

  template <class Real, class FormSet>
  static HWY_INLINE void hessian(const PairViewOf<Real, FormSet>& d, const Half<Real>& hi, int ii, const JBlock<Real>& j,
                                 const PairDistance<SimdVec<Real>>& p, SimdVec<Real>& a, SimdVec<Real>& b) {
    a = b = SimdVec<Real>::zero();
    add_hessian<0>(d, hi, ii, j, p, a, b);
  }

 private:
  template <std::size_t I>
  using Nth = std::tuple_element_t<I, std::tuple<Form...>>;

  // Not std::apply: a lambda would lack the target's attributes and stay a call.
  template <class Real, class FormSet, std::size_t... I>
  static HWY_INLINE void load_each(const PairViewOf<Real, FormSet>& d, int ib, Half<Real>& hi, std::index_sequence<I...>) {
    (std::get<I>(hi).load(d, constants_of<Nth<I>>(d), ib), ...);
  }

  template <std::size_t I, bool kEnergies, class Real, class FormSet>
  static HWY_INLINE void add_energy_force(const PairViewOf<Real, FormSet>& d, const Half<Real>& hi, int ii,
                                          const JBlock<Real>& j, const PairDistance<SimdVec<Real>>& p, SimdMaskOf<Real> inside,
                                          SimdVec<Real>& g, SimdVec<Real>* e) {
    if constexpr (I < sizeof...(Form)) {
      using F = Nth<I>;
      const auto& rows = std::get<I>(hi);
      if (rows.active(ii)) {
        const auto& k = constants_of<F>(d);
        const auto pair = rows.at(ii, j);
        SimdVec<Real> v;
        if constexpr (I == 0) {
          F::energy_force(k, pair, p, v, g);
        } else if constexpr (requires { F::add_energy_force(k, pair, p, v, g); }) {
          F::add_energy_force(k, pair, p, v, g);
        } else {
          SimdVec<Real> gf;
          F::energy_force(k, pair, p, v, gf);
          g += gf;
        }
        if constexpr (kEnergies) e[static_cast<int>(ConstantsOf<F>::kEnergy)] += keep(inside, v);
      }
      add_energy_force<I + 1, kEnergies>(d, hi, ii, j, p, inside, g, e);
    }
  }

  template <std::size_t I, class Real, class FormSet>
  static HWY_INLINE void add_hessian(const PairViewOf<Real, FormSet>& d, const Half<Real>& hi, int ii, const JBlock<Real>& j,
                                     const PairDistance<SimdVec<Real>>& p, SimdVec<Real>& a, SimdVec<Real>& b) {
    if constexpr (I < sizeof...(Form)) {
      using F = Nth<I>;
      const auto& rows = std::get<I>(hi);
      if (rows.active(ii)) {
        const auto& k = constants_of<F>(d);
        const auto pair = rows.at(ii, j);
        if constexpr (I == 0) {
          F::hessian(k, pair, p, a, b);
        } else {
          SimdVec<Real> af, bf;
          F::hessian(k, pair, p, af, bf);
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
  static_assert(PairRowsOf<B, double>::active(0), "SharedSwitch: B must act on every row");
  template <class Real>
  using Half = std::tuple<PairRowsOf<A, Real>, PairRowsOf<B, Real>>;

  static bool selected(const PairFormConstants& forms) {
    const auto& a = std::get<ConstantsOf<A>>(forms);
    const auto& b = std::get<ConstantsOf<B>>(forms);
    return a.present() && b.present() && a.potential_switched() && b.potential_switched() &&
           a.potential_switch().r_switch == b.potential_switch().r_switch &&
           a.potential_switch().smoothness == b.potential_switch().smoothness && present_forms(forms) == 2;
  }

  template <class Real, class FormSet>
  static HWY_INLINE void load(const PairViewOf<Real, FormSet>& d, int ib, Half<Real>& hi) {
    std::get<0>(hi).load(d, constants_of<A>(d), ib);
    std::get<1>(hi).load(d, constants_of<B>(d), ib);
  }

  template <bool kEnergies, class Real, class FormSet>
  static HWY_INLINE void energy_force(const PairViewOf<Real, FormSet>& d, const Half<Real>& hi, int ii, const JBlock<Real>& j,
                                      const PairDistance<SimdVec<Real>>& p, SimdMaskOf<Real> inside, SimdVec<Real>& g,
                                      SimdVec<Real>* e) {
    using V = SimdVec<Real>;
    const V r = p.r2 * p.rinv;
    V v = V::zero();
    g = V::zero();
    if (std::get<0>(hi).active(ii)) A::energy_force(constants_of<A>(d), std::get<0>(hi).at(ii, j), p, v, g);
    V vb, gb, s, ds;
    B::energy_force(constants_of<B>(d), std::get<1>(hi).at(ii, j), p, vb, gb);
    switch_value_slope(switch_of(d), r, s, ds);
    apply_switch_factors(s, ds, p.rinv, v, g);
    apply_switch_factors(s, ds, p.rinv, vb, gb);
    if constexpr (kEnergies) {
      e[static_cast<int>(ConstantsOf<A>::kEnergy)] += keep(inside, v);
      e[static_cast<int>(ConstantsOf<B>::kEnergy)] += keep(inside, vb);
    }
    g += gb;
  }

  // The coefficients of U = U_A + U_B unswitched, then of U·S. Each call takes its parameters from
  // at() (the compiler merges the loads): holding them in one variable changes which products the
  // compiler fuses into multiply-adds, so the single-precision results would round differently.
  template <class Real, class FormSet>
  static HWY_INLINE void hessian(const PairViewOf<Real, FormSet>& d, const Half<Real>& hi, int ii, const JBlock<Real>& j,
                                 const PairDistance<SimdVec<Real>>& p, SimdVec<Real>& a, SimdVec<Real>& b) {
    using V = SimdVec<Real>;
    const V r = p.r2 * p.rinv;
    V u, unused;
    B::hessian(constants_of<B>(d), std::get<1>(hi).at(ii, j), p, a, b);
    B::energy_force(constants_of<B>(d), std::get<1>(hi).at(ii, j), p, u, unused);
    if (std::get<0>(hi).active(ii)) {
      V a_a, b_a, u_a;
      A::hessian(constants_of<A>(d), std::get<0>(hi).at(ii, j), p, a_a, b_a);
      A::energy_force(constants_of<A>(d), std::get<0>(hi).at(ii, j), p, u_a, unused);
      a += a_a;
      b += b_a;
      u += u_a;
    }
    apply_switch_hessian(switch_of(d), u, r, p.rinv, a, b);
  }

 private:
  template <class Real, class FormSet>
  static const SwitchFunction& switch_of(const PairViewOf<Real, FormSet>& d) {
    return constants_of<A>(d).potential_switch();
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

#endif  // VIMD_FORCEFIELDS_NONBONDED_KERNEL_COMBINATIONS_INL_H_
