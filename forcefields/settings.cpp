#include "forcefields/settings.hpp"

namespace vimd {

namespace {

constexpr OnContinue kMustMatch = OnContinue::must_match;

// The pair forms: the cut-off, LJ and its modifier, the Coulomb method and its modifier.
void add_pair_form_keys(std::vector<ConfigKey>& k) {
  const std::vector<std::string> vdw_modifiers = {"none", "potential-shift", "force-switch", "potential-switch"};
  k.push_back(number_key<&ForceFieldConfig::cutoff>(
      "forcefield", "cutoff", "number, nm", kMustMatch, "cut-off of LJ and Coulomb (rvdw = rcoulomb)",
      [](double v) { return v > 0; }, "cutoff must be positive (nm)"));
  k.push_back(choice_key<&ForceFieldConfig::vdw_modifier>(
      "forcefield", "vdw_modifier", vdw_modifiers, kMustMatch, "LJ at the cut-off, as GROMACS's vdw-modifier"));
  k.push_back(number_key<&ForceFieldConfig::vdw_switch>(
      "forcefield", "vdw_switch", "number, nm", kMustMatch, "start of the LJ switch (force-switch, potential-switch)",
      [](double v) { return v >= 0; }, "vdw_switch must not be negative (nm)"));
  k.push_back(choice_key<&ForceFieldConfig::coulomb>(
      "forcefield", "coulomb", {"reaction-field", "cutoff", "pme", "none"}, kMustMatch,
      "electrostatics: reaction field (epsilon_rf), plain cut-off, smooth particle-mesh Ewald, or none"));
  k.push_back(choice_key<&ForceFieldConfig::coulomb_modifier>(
      "forcefield", "coulomb_modifier", {"none", "potential-shift", "potential-switch"}, kMustMatch,
      "as GROMACS's; reaction field is shifted either way; potential-switch multiplies Coulomb (PME: its real "
      "space) by the switch (not a GROMACS option)"));
  k.push_back(number_key<&ForceFieldConfig::coulomb_switch>(
      "forcefield", "coulomb_switch", "number, nm", kMustMatch,
      "start of the Coulomb switch (required with coulomb_modifier = \"potential-switch\")",
      [](double v) { return v >= 0; }, "coulomb_switch must not be negative (nm)"));
  k.push_back({"forcefield",
               "switch_smoothness",
               "integer, 2-6",
               {},
               kMustMatch,
               "k: potential-switched pair potentials are C^k at both ends of the switch (2 is GROMACS's)",
               [](const KeyInput& in, RunConfig& c) {
                 const long smoothness = in.integer();
                 in.require(smoothness >= 2 && smoothness <= 6,
                            "switch_smoothness must be between 2 and 6 (continuous derivatives of a potential-switch "
                            "pair potential; 2 is GROMACS's), got " +
                                std::to_string(smoothness));
                 forcefield_config(c).switch_smoothness = static_cast<int>(smoothness);
               },
               [](const RunConfig& c) { return std::to_string(forcefield_config(c).switch_smoothness); }});
  k.push_back(number_key<&ForceFieldConfig::epsilon_r>(
      "forcefield", "epsilon_r", "number", kMustMatch, "relative dielectric constant", [](double v) { return v > 0; },
      "epsilon_r must be positive"));
  k.push_back(number_key<&ForceFieldConfig::epsilon_rf>(
      "forcefield", "epsilon_rf", "number", kMustMatch, "reaction-field dielectric constant; 0 means infinity",
      [](double v) { return v >= 0; }, "epsilon_rf must not be negative (0 means infinity)"));
}

// Smooth particle-mesh Ewald (coulomb = "pme"), as GROMACS's mdp options of the same names.
void add_pme_keys(std::vector<ConfigKey>& k) {
  k.push_back(number_key<&ForceFieldConfig::ewald_rtol>(
      "forcefield", "ewald_rtol", "number", kMustMatch,
      "PME: erfc(beta r) at the cut-off, or at coulomb_switch when the real space is switched",
      [](double v) { return v > 0 && v < 0.1; }, "ewald_rtol must be between 0 and 0.1 (exclusive)"));
  const std::string orders = std::to_string(kMinPmeOrder) + "-" + std::to_string(kMaxPmeOrder);
  k.push_back(integer_key<&ForceFieldConfig::pme_order>(
      "forcefield", "pme_order", "integer, " + orders, kMustMatch,
      "PME: B-spline interpolation order (GROMACS's pme-order)",
      [](long v) { return v >= kMinPmeOrder && v <= kMaxPmeOrder; },
      "pme_order must be between " + std::to_string(kMinPmeOrder) + " and " + std::to_string(kMaxPmeOrder)));
  k.push_back(number_key<&ForceFieldConfig::fourier_spacing>(
      "forcefield", "fourier_spacing", "number, nm", kMustMatch,
      "PME: largest grid spacing; the grid sizes follow as GROMACS chooses them", [](double v) { return v > 0; },
      "fourier_spacing must be positive (nm)"));
  for (int d = 0; d < 3; ++d) {
    const std::string name = std::string("fourier_n") + "xyz"[d];
    k.push_back({"forcefield",
                 name,
                 "integer",
                 {},
                 kMustMatch,
                 std::string("PME: grid points along ") + "xyz"[d] + " (unset or 0: from fourier_spacing)",
                 [d, name](const KeyInput& in, RunConfig& c) {
                   const long n = in.integer();
                   in.require(n >= 0 && n <= kMaxFourierPoints,
                              name + " must be between 0 and " + std::to_string(kMaxFourierPoints));
                   forcefield_config(c).fourier_n[d] = static_cast<int>(n);
                 },
                 [d](const RunConfig& c) { return std::to_string(forcefield_config(c).fourier_n[d]); }});
  }
}

// The pair list the kernels run over and the searched list it is pruned from.
void add_pair_list_keys(std::vector<ConfigKey>& k) {
  k.push_back(number_key<&ForceFieldConfig::neighbor_skin>(
      "forcefield", "neighbor_skin", "number, nm", kMustMatch,
      "buffer of the pair list the kernels run over; re-pruned when an atom moved half of it",
      [](double v) { return v >= 0; }, "neighbor_skin must not be negative (nm)"));
  k.push_back({"forcefield",
               "neighbor_search_skin",
               "number, nm",
               {},
               kMustMatch,
               "buffer of the searched list it is pruned from (unset: neighbor_skin + 0.6, as the box allows)",
               [](const KeyInput& in, RunConfig& c) { forcefield_config(c).neighbor_search_skin = in.number(); },
               [](const RunConfig& c) {
                 const std::optional<double>& skin = forcefield_config(c).neighbor_search_skin;
                 return skin ? exact_text(*skin) : std::string("(automatic)");
               }});
}

}  // namespace

std::vector<ConfigKey> forcefield_keys() {
  std::vector<ConfigKey> k;
  add_pair_form_keys(k);
  add_pme_keys(k);
  add_pair_list_keys(k);
  k.push_back(choice_key<&ForceFieldConfig::precision>(
      "forcefield", "precision", {"double", "mixed"}, kMustMatch,
      "mixed: pair forces in single precision, as GROMACS's default build (not with vi or rk)"));
  return k;
}

std::vector<ConfigRule> forcefield_rules() {
  const auto vdw_switch_inside_cutoff = [](const GivenKeys& given, const RunConfig& c) {
    const ForceFieldConfig& ff = forcefield_config(c);
    if (ff.vdw_modifier != "force-switch" && ff.vdw_modifier != "potential-switch") return;
    const KeyInput* switch_start = given.find("forcefield", "vdw_switch");
    const KeyInput& where = switch_start ? *switch_start : *given.find("forcefield", "vdw_modifier");
    where.require(ff.vdw_switch < ff.cutoff, "vdw_switch (" + format_number(ff.vdw_switch) +
                                                 " nm) must be smaller than cutoff (" + format_number(ff.cutoff) +
                                                 " nm) for " + ff.vdw_modifier);
  };
  const auto coulomb_switch_inside_cutoff = [](const GivenKeys& given, const RunConfig& c) {
    const ForceFieldConfig& ff = forcefield_config(c);
    if (ff.coulomb_modifier != "potential-switch") return;
    const KeyInput& modifier = *given.find("forcefield", "coulomb_modifier");
    modifier.require(
        ff.coulomb != "none",
        "coulomb_modifier = \"potential-switch\" needs coulomb = \"reaction-field\", \"cutoff\" or \"pme\"");
    const KeyInput* start = given.find("forcefield", "coulomb_switch");
    modifier.require(start != nullptr,
                     "coulomb_modifier = \"potential-switch\" needs coulomb_switch (nm, where the switch starts)");
    start->require(ff.coulomb_switch < ff.cutoff, "coulomb_switch (" + format_number(ff.coulomb_switch) +
                                                      " nm) must be smaller than cutoff (" + format_number(ff.cutoff) +
                                                      " nm)");
  };
  const auto search_skin_over_skin = [](const GivenKeys& given, const RunConfig& c) {
    const ForceFieldConfig& ff = forcefield_config(c);
    if (const KeyInput* search_skin = given.find("forcefield", "neighbor_search_skin"))
      search_skin->require(*ff.neighbor_search_skin >= ff.neighbor_skin,
                           "neighbor_search_skin (" + format_number(*ff.neighbor_search_skin) +
                               " nm) must not be smaller than neighbor_skin (" + format_number(ff.neighbor_skin) +
                               " nm)");
  };
  return {vdw_switch_inside_cutoff, coulomb_switch_inside_cutoff, search_skin_over_skin};
}

}  // namespace vimd
