#pragma once
// The registry of nonbonded pair forms: the pair loop evaluates what is listed here, and nothing
// else names a form. A configuration uses at most one form of each slot (exactly one vdw form);
// the kernels are compiled for every combination of their variants (pair_form.hpp: what a form
// defines; docs/adding-a-force-term.md: how to add one; pair_forms-inl.h: their kernels).
#include <tuple>

#include "engine/errors.hpp"
#include "forcefields/nonbonded/ewald.hpp"
#include "forcefields/nonbonded/lennard_jones.hpp"
#include "forcefields/nonbonded/reaction_field.hpp"

namespace vimd {

template <FormConstants... Form>
struct PairFormList {};

using VdwForms = PairFormList<LjConstants>;
using CoulombForms = PairFormList<ReactionField, EwaldRealSpace>;

// The constants of every listed form (std::get<LjConstants>(forms), ...), built from a configuration.
// Every value of `coulomb` but "none" belongs to a Coulomb form; one that no form takes is refused.
template <class Vdw, class Coulomb>
struct PairFormConstantsOf;
template <class... V, class... C>
struct PairFormConstantsOf<PairFormList<V...>, PairFormList<C...>> {
  using type = std::tuple<V..., C...>;
  static type from_config(const ForceFieldConfig& config) {
    type forms{V::from_config(config)..., C::from_config(config)...};
    if (config.coulomb != "none" && !(std::get<C>(forms).present() || ...))
      throw SettingError("forcefield", "coulomb", "unknown coulomb '" + config.coulomb + "'");
    return forms;
  }
};
using PairFormConstants = PairFormConstantsOf<VdwForms, CoulombForms>::type;
inline PairFormConstants make_pair_form_constants(const ForceFieldConfig& config) {
  return PairFormConstantsOf<VdwForms, CoulombForms>::from_config(config);
}

// f(constants) for every form present in the configuration.
template <class F>
void for_each_present_form(const PairFormConstants& forms, F&& f) {
  std::apply([&](const auto&... form) { ((form.present() ? f(form) : void()), ...); }, forms);
}

}  // namespace vimd
