#include "forcefields/input_checks.hpp"

#include <algorithm>
#include <cmath>

#include "engine/errors.hpp"
#include "forcefields/nonbonded/nonbonded_pair_term.hpp"
#include "forcefields/settings.hpp"

namespace vimd {

namespace {

// Every pair inside the cut-off must have one image only: the box must be at least twice the
// cut-off. Whether the pair lists' buffers fit as well is the pair term's to say (pair_list_warnings).
std::vector<std::string> check_box(const RunConfig& c, const Box& box, int box_line) {
  const ForceFieldConfig& ff = forcefield_config(c);
  for (int k = 0; k < 3; ++k)
    if (box.length[k] > 0 && box.length[k] < 2 * ff.cutoff)
      throw InputError(c.structure.string(), box_line,
                       "box length " + format_number(box.length[k]) + " nm in " + "xyz"[k] +
                           " is shorter than twice the cutoff = 2 x " + format_number(ff.cutoff) + " nm set in " +
                           c.file.string() + ": use a larger box or a smaller cutoff");
  return pair_list_warnings(c, box);
}

std::optional<std::string> net_charge_warning(const System& s, const RunConfig& c) {
  const ForceFieldConfig& ff = forcefield_config(c);
  const double q = s.charge.sum();
  // grompp's threshold for its own note on a net charge.
  if (ff.coulomb == "none" || std::abs(q) < 1e-4) return std::nullopt;
  if (ff.coulomb == "pme")
    return c.topology.string() + ": the system has a net charge of " + format_number(q) +
           " e: Ewald with a net charge adds a uniform neutralising background (its energy is in coulomb_recip, "
           "as GROMACS's), which can cause artifacts such as ions drifting into regions of low dielectric; "
           "add counter-ions unless this is intended";
  return c.topology.string() + ": the system has a net charge of " + format_number(q) + " e (coulomb = \"" +
         ff.coulomb + "\"): reaction-field assumes a neutral system (its medium beyond the cut-off is a " +
         "neutral dielectric), so with a net charge the energy depends on the cut-off and epsilon_rf and is not " +
         "comparable with other setups; add counter-ions unless this is intended";
}

}  // namespace

std::vector<std::string> check_force_field_input(const RunConfig& config, const System& system, const Box& box,
                                                 int box_line) {
  std::vector<std::string> warnings = check_box(config, box, box_line);
  if (auto warning = net_charge_warning(system, config)) warnings.push_back(std::move(*warning));
  return warnings;
}

}  // namespace vimd
