#include "forcefields/input_checks.hpp"

#include <algorithm>
#include <cmath>

#include "engine/errors.hpp"
#include "engine/neighbor_list.hpp"
#include "forcefields/settings.hpp"

namespace vimd {

namespace {

double shortest_length(const Box& box) {
  double shortest = INFINITY;
  for (int k = 0; k < 3; ++k)
    if (box.length[k] > 0) shortest = std::min(shortest, box.length[k]);
  return shortest;
}

// Every pair inside the cut-off must have one image only: the box must be at least twice the
// cut-off. The pair list's buffers must fit as well; where they do not, the list uses what the box
// allows, as GROMACS shrinks its buffer, and a warning says so (a run then searches more often; a
// single point does not care).
std::vector<std::string> check_box(const RunConfig& c, const Box& box, int box_line) {
  const ForceFieldConfig& ff = forcefield_config(c);
  for (int k = 0; k < 3; ++k)
    if (box.length[k] > 0 && box.length[k] < 2 * ff.cutoff)
      throw InputError(c.structure.string(), box_line,
                       "box length " + format_number(box.length[k]) + " nm in " + "xyz"[k] +
                           " is shorter than twice the cutoff = 2 x " + format_number(ff.cutoff) + " nm set in " +
                           c.file.string() + ": use a larger box or a smaller cutoff");
  std::vector<std::string> warnings;
  const auto fit = [&](const std::string& key, double skin) {
    const double fitting = skin_fitting_box(box, ff.cutoff, skin);
    if (fitting < skin)
      warnings.push_back(c.structure.string() + ": the box (" + format_number(shortest_length(box)) +
                         " nm at its shortest) leaves room for cutoff + " + key + " up to half its length, so the " +
                         key + " of " + format_number(skin) + " nm set in " + c.file.string() + " is cut to " +
                         format_number(fitting) + " nm (as GROMACS shrinks its pair-list buffer to what the box "
                         "allows); a run searches for pairs more often");
  };
  fit("neighbor_skin", ff.neighbor_skin);
  if (ff.neighbor_search_skin) fit("neighbor_search_skin", *ff.neighbor_search_skin);
  return warnings;
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
