#include "forcefields/nonbonded/lennard_jones.hpp"

#include <cmath>
#include <cstdio>
#include <sstream>

#include "engine/errors.hpp"

namespace vimd {

VdwModifier parse_vdw_modifier(const std::string& name) {
  if (name == "none") return VdwModifier::none;
  if (name == "potential-shift") return VdwModifier::potential_shift;
  if (name == "force-switch") return VdwModifier::force_switch;
  if (name == "potential-switch") return VdwModifier::potential_switch;
  throw SettingError(
      "forcefield", "vdw_modifier",
      "unknown vdw_modifier '" + name + "' (expected none, potential-shift, force-switch or potential-switch)");
}

LjConstants make_lj_constants(VdwModifier modifier, double cutoff, double r_switch, int smoothness) {
  LjConstants k;
  k.modifier = modifier;
  k.cutoff = cutoff;
  const double rc = cutoff;
  switch (modifier) {
    case VdwModifier::none:
      break;
    case VdwModifier::potential_shift:
      k.shift6 = -std::pow(rc, -6);
      k.shift12 = -std::pow(rc, -12);
      break;
    case VdwModifier::force_switch:
    case VdwModifier::potential_switch: {
      if (!(r_switch >= 0 && r_switch < rc)) {
        std::ostringstream msg;
        msg << "vdw_switch (" << r_switch << " nm) must lie in [0, cutoff = " << rc
            << " nm) for the switched modifiers";
        throw SettingError("forcefield", "vdw_switch", msg.str());
      }
      k.r_switch = r_switch;
      const double w = rc - r_switch;
      if (modifier == VdwModifier::potential_switch) {
        k.sw = make_switch_function(r_switch, rc, smoothness, "vdw_switch");
      } else {
        // A = −p((p+4)rc − (p+1)r1)/(rc^(p+2)(rc−r1)²), B = p((p+3)rc − (p+1)r1)/(rc^(p+2)(rc−r1)³),
        // C = rc^-p − A/3 (rc−r1)³ − B/4 (rc−r1)⁴, so that force and potential vanish at rc.
        auto constants = [&](double p, double& a, double& b, double& shift) {
          a = -p * ((p + 4) * rc - (p + 1) * r_switch) / (std::pow(rc, p + 2) * w * w);
          b = p * ((p + 3) * rc - (p + 1) * r_switch) / (std::pow(rc, p + 2) * w * w * w);
          shift = -(std::pow(rc, -p) - a / 3 * std::pow(w, 3) - b / 4 * std::pow(w, 4));
        };
        constants(6, k.a6, k.b6, k.shift6);
        constants(12, k.a12, k.b12, k.shift12);
      }
      break;
    }
  }
  return k;
}

LjConstants LjConstants::from_config(const ForceFieldConfig& config) {
  return make_lj_constants(parse_vdw_modifier(config.vdw_modifier), config.cutoff, config.vdw_switch,
                           config.switch_smoothness);
}

int LjConstants::continuity(double) const { return lj_continuity(modifier, sw.smoothness); }

std::string LjConstants::describe(double cutoff_distance) const {
  const int n = continuity(cutoff_distance);
  std::string text = "LJ " + (n < 0 ? std::string("discontinuous") : "C^" + std::to_string(n));
  char buf[160] = "";
  if (modifier == VdwModifier::none) std::snprintf(buf, sizeof buf, " (the energy jumps at the cut-off)");
  if (modifier == VdwModifier::potential_shift) std::snprintf(buf, sizeof buf, " (the force jumps at the cut-off)");
  if (modifier == VdwModifier::force_switch)
    std::snprintf(buf, sizeof buf, " (force-switch %g-%g nm)", r_switch, cutoff_distance);
  if (modifier == VdwModifier::potential_switch)
    std::snprintf(buf, sizeof buf, " (potential-switch %g-%g nm, switch_smoothness %d)", r_switch, cutoff_distance,
                  sw.smoothness);
  return text + buf;
}

int lj_continuity(VdwModifier modifier, int smoothness) {
  switch (modifier) {
    case VdwModifier::none:
      return -1;
    case VdwModifier::potential_shift:
      return 0;
    case VdwModifier::force_switch:  // the force and its slope vanish at rc; its curvature jumps at r_switch
      return 2;
    case VdwModifier::potential_switch:
      return smoothness;
  }
  return -1;
}

}  // namespace vimd
