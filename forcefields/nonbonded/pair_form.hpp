#pragma once
// What a nonbonded pair form is (Lennard-Jones, reaction field, ...): the contract between a form
// and the one pair loop (pair_loops-inl.h, nonbonded_pair_term.cpp), which knows no form by
// name. The forms are listed in pair_forms.hpp; docs/adding-a-force-term.md is the recipe.
//
// A form is a family of variants (its modifiers), in two parts:
//
// Its constants (FormConstants below), target-independent, in <form>.hpp: built once from the
// configuration, carried by value in the pair loop's view (PairViewOf::forms), read by the kernels.
//
// Its kernels, in <form>_kernels.h, compiled once per SIMD target: a specialisation
// PairForm<Constants, variant> per variant with the per-pair energy, force factor and Hessian
// coefficients as branch-free templates on the number type, of the pair's distance and of the
// per-pair parameters the constants declare (kParameters), which the loop loads
// (pair_form-inl.h describes the members).
#include <concepts>
#include <string>
#include <type_traits>

#include "forcefields/nonbonded/switch_function.hpp"
#include "forcefields/settings.hpp"

namespace vimd {

// The energy a form reports to (NonbondedPairTerm::energy_names: "lj", "coulomb").
enum class PairEnergy { vdw = 0, coulomb = 1 };
constexpr int kPairEnergies = 2;

// The per-pair parameters a form's kernels read, loaded by the pair loop for every pair:
//   charge_product: qq = prefactor · q_i q_j, with the constants' member `prefactor` (f/ε_r);
//   lennard_jones:  c6 and c12 of the two atoms' types (atoms whose type has no LJ with any type
//                   skip the form: its terms would be exact zeros).
enum class PairParameters { charge_product, lennard_jones };
template <PairParameters K, class T>
struct PairParametersOf;
template <class T>
struct PairParametersOf<PairParameters::charge_product, T> {
  T qq;
};
template <class T>
struct PairParametersOf<PairParameters::lennard_jones, T> {
  T c6, c12;
};
template <class T>
using ChargeProduct = PairParametersOf<PairParameters::charge_product, T>;
template <class T>
using LennardJonesPair = PairParametersOf<PairParameters::lennard_jones, T>;

// A pair's distance as the kernels read it: r², 1/r and 1/r² (T: a vector of pairs, or double).
template <class T>
struct PairDistance {
  T r2, rinv, rinv2;
};

// The constants of a pair form. Beyond these members, a form may have
//   double self_energy(double sum_q2) const;   a constant energy from the atoms' charges;
//   static constexpr bool kExcludedPairs = true, and an excluded-pair term in its -inl.h:
//     what the excluded pairs inside the cut-off still feel;
//   const SwitchFunction& potential_switch() const, bool potential_switched() const and
//     static constexpr auto kUnswitched (the variant without the switch): the form can share
//     one evaluation of the switch with another switched form (SharedSwitch in kernel_combinations-inl.h).
template <class C>
concept FormConstants = requires(const C& c, const ForceFieldConfig& config, double cutoff) {
  { C::from_config(config) } -> std::same_as<C>;
  { c.present() } -> std::convertible_to<bool>;  // the configuration uses this form at all
  { c.variant() } -> std::same_as<std::remove_cvref_t<decltype(C::kVariants[0])>>;  // one of kVariants
  { C::kEnergy } -> std::convertible_to<PairEnergy>;
  { C::kParameters } -> std::convertible_to<PairParameters>;
  // n such that the pair potential is C^n over the whole range, cut-off included (−1: the energy
  // itself jumps there). n ≥ 1 lets a variational step leave its pair set free.
  { c.continuity(cutoff) } -> std::same_as<int>;
  // That smoothness in words, for vimd check: "LJ C^0 (the force jumps at the cut-off)".
  { c.describe(cutoff) } -> std::same_as<std::string>;
};

// Whether the excluded pairs of form C still feel it (kExcludedPairs above).
template <class C>
constexpr bool kHasExcludedPairs = requires { requires C::kExcludedPairs; };

}  // namespace vimd
