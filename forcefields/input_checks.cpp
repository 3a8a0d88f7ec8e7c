#include "forcefields/input_checks.hpp"

#include <algorithm>
#include <cmath>

#include "engine/errors.hpp"
#include "forcefields/nonbonded/ewald.hpp"
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

// How far the mesh's estimated error in the forces between charges may exceed the real space's at
// ewald_rtol (both as `gmx pme_error` estimates them; both grow as √(charge density), so their
// ratio is the settings', whatever the system). GROMACS's defaults (ewald_rtol 1e-5,
// fourier_spacing 0.12 nm, pme_order 4) give 17-50 (cut-off 1.2-0.9 nm), 180 at spacing 0.16 nm;
// the repository's inputs at most 80 (real space switched from 0.8 nm, order 4). 1000 leaves those
// a margin of 5 and refuses a mesh three orders of magnitude less accurate than ewald_rtol says:
// e.g. coulomb_switch = 0.4 nm on the default grid (1900 times; the energy of inputs/cluster8 40 %
// off).
constexpr double kMeshErrorFactor = 1000;
// The suggested spacing puts the mesh where GROMACS's defaults put it with a 1 nm cut-off (33
// times): at the refusal's bound the energy can still be 10 % off.
constexpr double kSuggestedMeshErrorFactor = 30;

// The key to blame for a mesh too coarse for beta: the first the run file gives of the grid's,
// ewald_rtol and the switch (whence beta), else the grid's.
std::string mesh_error_key(const RunConfig& c, const std::string& grid_key) {
  const ForceFieldConfig& ff = forcefield_config(c);
  std::vector<std::string> keys = {grid_key, "ewald_rtol"};
  if (ff.coulomb_modifier == "potential-switch") keys.push_back("coulomb_switch");
  for (const std::string& key : keys)
    if (c.sources.key_lines.count({"forcefield", key})) return key;
  return grid_key;
}

// The largest spacing (nearly) whose grid meets kSuggestedMeshErrorFactor: the error falls as
// spacing^pme_order while the aliasing is small; a few steps of that law, each checked. 0 when none
// is found (a beta no grid of this order meets, or a grid beyond memory).
double suggested_spacing(const ForceFieldConfig& ff, const System& s, const Box& box, double spacing,
                         const PmeForceErrors& errors) {
  if (!(errors.real_space > 0)) return 0;
  ForceFieldConfig finer = ff;
  finer.fourier_n = {0, 0, 0};
  PmeForceErrors now = errors;
  for (int attempt = 0; attempt < 8; ++attempt) {
    spacing *= 0.95 * std::pow(kSuggestedMeshErrorFactor * now.real_space / now.mesh.pairs, 1.0 / ff.pme_order);
    finer.fourier_spacing = std::floor(spacing * 1000) / 1000;  // as a user would write it
    if (!(finer.fourier_spacing > 0)) return 0;
    try {
      now = pme_force_errors(finer, s, box, pme_grid_size(finer, box));
    } catch (const SettingError&) {  // more memory than the machine has
      return 0;
    }
    if (now.mesh.pairs <= kSuggestedMeshErrorFactor * now.real_space) return finer.fourier_spacing;
  }
  return 0;
}

// The mesh must keep ewald_rtol's promise within kMeshErrorFactor; pme_grid_size refuses a grid
// beyond memory.
void check_pme_grid(const RunConfig& c, const System& s, const Box& box) {
  const ForceFieldConfig& ff = forcefield_config(c);
  if (ff.coulomb != "pme") return;
  const std::array<int, 3> grid = pme_grid_size(ff, box);
  const PmeForceErrors errors = pme_force_errors(ff, s, box, grid);
  if (errors.mesh.pairs <= kMeshErrorFactor * errors.real_space) return;
  const bool given = ff.fourier_n[0] > 0 || ff.fourier_n[1] > 0 || ff.fourier_n[2] > 0;
  double spacing = 0;
  for (int d = 0; d < 3; ++d) spacing = std::max(spacing, box.length[d] / grid[d]);
  const double suggested = suggested_spacing(ff, s, box, spacing, errors);
  char text[700];
  std::snprintf(text, sizeof text,
                "the PME grid %d x %d x %d (spacing up to %.3g nm, pme_order %d) is too coarse for beta = %.4g nm^-1: "
                "its estimated RMS error in the forces between charges (gmx pme_error's estimate) is %.3g kJ/mol/nm, "
                "%.3g times the %.3g kJ/mol/nm ewald_rtol = %g promises in real space at r = %g nm; more than %g "
                "times is refused. ",
                grid[0], grid[1], grid[2], spacing, ff.pme_order, EwaldRealSpace::from_config(ff).beta,
                errors.mesh.pairs, errors.mesh.pairs / errors.real_space, errors.real_space, ff.ewald_rtol,
                ewald_rtol_distance(ff), kMeshErrorFactor);
  const std::string within = "within " + format_number(kSuggestedMeshErrorFactor) + " times";
  const std::string smaller_beta =
      std::string("a higher pme_order or a smaller beta (a larger ewald_rtol or ") +
      (ff.coulomb_modifier == "potential-switch" ? "coulomb_switch)" : "cutoff)");
  const std::string advice =
      suggested > 0 ? "fourier_spacing = " + format_number(suggested) + " nm" +
                          (given ? " (with fourier_nx/ny/nz unset)" : "") + " brings it " + within +
                          " (as GROMACS's defaults with a 1 nm cut-off); " + smaller_beta + " also helps"
                    : "no grid of this order within memory brings it " + within + ": use " + smaller_beta;
  throw SettingError("forcefield", mesh_error_key(c, pme_grid_key(ff)), text + advice);
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
  check_pme_grid(config, system, box);
  if (auto warning = net_charge_warning(system, config)) warnings.push_back(std::move(*warning));
  return warnings;
}

}  // namespace vimd
