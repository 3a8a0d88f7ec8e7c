#include "forcefields/nonbonded/reaction_field.hpp"

#include <cmath>
#include <cstdio>

#include "engine/errors.hpp"
#include "engine/types.hpp"

namespace vimd {

ReactionField make_reaction_field(const std::string& coulomb, double epsilon_r, double epsilon_rf, double cutoff,
                                  const std::string& modifier, double r_switch, int smoothness) {
  ReactionField rf;
  if (modifier != "none" && modifier != "potential-shift" && modifier != "potential-switch")
    throw SettingError("forcefield", "coulomb_modifier",
                       "unknown coulomb_modifier '" + modifier + "' (expected none, potential-shift or potential-switch)");
  if (coulomb == "none") {
    if (modifier == "potential-switch")
      throw SettingError("forcefield", "coulomb_modifier",
                         "coulomb_modifier = \"" + modifier + "\" needs a Coulomb interaction (coulomb is none)");
    return rf;
  }
  if (coulomb != "reaction-field" && coulomb != "cutoff")
    throw SettingError("forcefield", "coulomb",
                       "unknown coulomb '" + coulomb + "' (expected reaction-field, cutoff or none)");
  if (!(epsilon_r > 0)) throw SettingError("forcefield", "epsilon_r", "epsilon_r must be positive");
  rf.kind = CoulombKind::reaction_field;
  rf.prefactor = kCoulomb / epsilon_r;
  const double rc3 = cutoff * cutoff * cutoff;
  if (coulomb == "cutoff") {
    rf.k_rf = 0;
  } else if (epsilon_rf == 0) {  // eps_rf = ∞ (conducting boundary)
    rf.k_rf = 1 / (2 * rc3);
  } else {
    if (!(epsilon_rf > 0))
      throw SettingError("forcefield", "epsilon_rf", "epsilon_rf must be positive, or 0 for infinity");
    rf.k_rf = (epsilon_rf - epsilon_r) / ((2 * epsilon_rf + epsilon_r) * rc3);
  }
  // GROMACS shifts reaction field always, a plain cut-off only with potential-shift.
  rf.c_rf = coulomb == "cutoff" && modifier == "none" ? 0.0 : 1 / cutoff + rf.k_rf * cutoff * cutoff;
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

std::string ReactionField::describe(double cutoff) const {
  const int n = continuity(cutoff);
  char buf[200];
  if (modifier == CoulombModifier::potential_switch)
    std::snprintf(buf, sizeof buf, "Coulomb C^%d (potential-switch %g-%g nm, switch_smoothness %d; C^%d at the cut-off)",
                  n, sw.r_switch, cutoff, n, n + 1);
  else
    std::snprintf(buf, sizeof buf, "Coulomb C^%d (%s)", n,
                  n == 0 ? "the force jumps at the cut-off" : "eps_rf = inf: the force's slope jumps at the cut-off");
  return buf;
}

int coulomb_continuity(const ReactionField& rf, double cutoff) {
  if (rf.modifier == CoulombModifier::potential_switch) return rf.sw.smoothness;
  return std::abs(2 * rf.k_rf * cutoff * cutoff * cutoff - 1) < 1e-12 ? 1 : 0;
}

}  // namespace vimd
