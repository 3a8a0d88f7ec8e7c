#include "forcefields/reaction_field.hpp"

#include <cmath>

#include "engine/errors.hpp"
#include "engine/types.hpp"

namespace vimd {

ReactionField make_reaction_field(const std::string& coulomb, double epsilon_r, double epsilon_rf, double cutoff,
                                  const std::string& modifier, double r_switch, int smoothness) {
  ReactionField rf;
  if (modifier != "none" && modifier != "potential-switch")
    throw InputError("[forcefield]", 0,
                     "unknown coulomb_modifier '" + modifier + "' (expected none or potential-switch)");
  if (coulomb == "none") {
    if (modifier != "none")
      throw InputError("[forcefield]", 0, "coulomb_modifier = \"" + modifier + "\" needs a Coulomb interaction (coulomb is none)");
    return rf;
  }
  if (coulomb != "reaction-field" && coulomb != "cutoff")
    throw InputError("[forcefield]", 0, "unknown coulomb '" + coulomb + "' (expected reaction-field, cutoff or none)");
  if (!(epsilon_r > 0)) throw InputError("[forcefield]", 0, "epsilon_r must be positive");
  rf.kind = CoulombKind::reaction_field;
  rf.prefactor = kCoulomb / epsilon_r;
  const double rc3 = cutoff * cutoff * cutoff;
  if (coulomb == "cutoff") {
    rf.k_rf = 0;
  } else if (epsilon_rf == 0) {  // eps_rf = ∞ (conducting boundary)
    rf.k_rf = 1 / (2 * rc3);
  } else {
    if (!(epsilon_rf > 0)) throw InputError("[forcefield]", 0, "epsilon_rf must be positive, or 0 for infinity");
    rf.k_rf = (epsilon_rf - epsilon_r) / ((2 * epsilon_rf + epsilon_r) * rc3);
  }
  rf.c_rf = 1 / cutoff + rf.k_rf * cutoff * cutoff;
  if (modifier == "potential-switch") {
    rf.modifier = CoulombModifier::potential_switch;
    rf.sw = make_switch_function(r_switch, cutoff, smoothness, "coulomb_switch");
  }
  return rf;
}

ReactionField ReactionField::from_config(const ForceFieldConfig& config) {
  // Another Coulomb form's value: no reaction field (make_pair_form_constants refuses a value no form takes).
  if (config.coulomb != "reaction-field" && config.coulomb != "cutoff" && config.coulomb != "none") return {};
  return make_reaction_field(config.coulomb, config.epsilon_r, config.epsilon_rf, config.cutoff,
                             config.coulomb_modifier, config.coulomb_switch, config.switch_smoothness);
}

int coulomb_continuity(const ReactionField& rf, double cutoff) {
  if (rf.modifier == CoulombModifier::potential_switch) return rf.sw.smoothness;
  return std::abs(2 * rf.k_rf * cutoff * cutoff * cutoff - 1) < 1e-12 ? 1 : 0;
}

}  // namespace vimd
