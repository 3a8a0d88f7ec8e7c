#pragma once
// What a nonbonded pair form is (Lennard-Jones, reaction field, ...): the contract between a form
// and the one pair loop (nonbonded_kernels-inl.h, nonbonded_pair_term.cpp), which knows no form by
// name. The forms are listed in pair_forms.hpp; docs/adding-a-force-term.md is the recipe.
//
// A form is a family of variants (its modifiers), in two parts:
//
// Its constants (FormConstants below), target-independent, in <form>.hpp: built once from the
// configuration, carried by value in the pair loop's view (PairViewOf::forms), read by the kernels.
//
// Its kernels, per SIMD target, in <form>-inl.h: a specialisation PairForm<Constants, variant> per
// variant (pair_form-inl.h describes its members: the per-pair energy, force factor and Hessian
// coefficients as functions of r², branch-free templates on the number type).
#include <concepts>
#include <string>
#include <type_traits>

#include "forcefields/settings.hpp"
#include "forcefields/switch_function.hpp"

namespace vimd {

// The energy a form reports to (NonbondedPairTerm::energy_names: "lj", "coulomb").
enum class PairEnergy { vdw = 0, coulomb = 1 };
constexpr int kPairEnergies = 2;

// The constants of a pair form. Beyond these members, a form may have
//   double self_energy(double sum_q2) const;   a constant energy from the atoms' charges;
//   static constexpr bool kExcludedPairs = true, and an excluded-pair term in its -inl.h:
//     what the excluded pairs inside the cut-off still feel;
//   const SwitchFunction& potential_switch() const, bool potential_switched() const and
//     static constexpr auto kUnswitched (the variant without the switch): the form can share
//     one evaluation of the switch with another switched form (SharedSwitch in nonbonded_kernels-inl.h).
template <class C>
concept FormConstants = requires(const C& c, const ForceFieldConfig& config, double cutoff) {
  { C::from_config(config) } -> std::same_as<C>;
  { c.present() } -> std::convertible_to<bool>;  // the configuration uses this form at all
  { c.variant() } -> std::same_as<std::remove_cvref_t<decltype(C::kVariants[0])>>;  // one of kVariants
  { C::kEnergy } -> std::convertible_to<PairEnergy>;
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
