#include "forcefields/nonbonded/ewald.hpp"

#include <omp.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iterator>

#include "engine/config_schema.hpp"
#include "engine/errors.hpp"
#include "engine/types.hpp"

namespace vimd {

double ewald_beta(double r, double rtol) {
  // Double β until erfc(β r) ≤ rtol, then halve the bracket [0, β] 60 more times than doublings.
  double beta = 5;
  int doublings = 0;
  do {
    ++doublings;
    beta *= 2;
  } while (std::erfc(beta * r) > rtol);
  double low = 0, high = beta;
  for (int k = 0; k < doublings + 60; ++k) {
    beta = (low + high) / 2;
    (std::erfc(beta * r) > rtol ? low : high) = beta;
  }
  return beta;
}

double ewald_rtol_distance(const ForceFieldConfig& config) {
  return config.coulomb_modifier == "potential-switch" ? config.coulomb_switch : config.cutoff;
}

EwaldRealSpace EwaldRealSpace::from_config(const ForceFieldConfig& config) {
  EwaldRealSpace e;
  if (config.coulomb != "pme") return e;
  if (!(config.epsilon_r > 0)) throw SettingError("forcefield", "epsilon_r", "epsilon_r must be positive");
  if (!(config.ewald_rtol > 0 && config.ewald_rtol < 0.1))
    throw SettingError("forcefield", "ewald_rtol", "ewald_rtol must be between 0 and 0.1 (exclusive)");
  e.enabled = true;
  e.prefactor = kCoulomb / config.epsilon_r;
  e.ewald_rtol = config.ewald_rtol;
  const std::string& modifier = config.coulomb_modifier;
  if (modifier == "potential-switch") {
    if (!(config.coulomb_switch > 0))
      throw SettingError("forcefield", "coulomb_switch",
                         "coulomb_switch must be positive with coulomb = \"pme\": erfc(beta coulomb_switch) = "
                         "ewald_rtol fixes beta");
    e.modifier = EwaldModifier::potential_switch;
    e.sw = make_switch_function(config.coulomb_switch, config.cutoff, config.switch_smoothness, "coulomb_switch");
  } else if (modifier != "none" && modifier != "potential-shift") {
    throw SettingError("forcefield", "coulomb_modifier",
                       "unknown coulomb_modifier '" + modifier + "' (expected none, potential-shift or potential-switch)");
  }
  e.beta = ewald_beta(ewald_rtol_distance(config), config.ewald_rtol);
  if (modifier == "potential-shift") e.shift = std::erfc(e.beta * config.cutoff) / config.cutoff;
  e.rational_corrections = e.beta * config.cutoff <= kRationalRange;
  return e;
}

int EwaldRealSpace::continuity(double) const {
  if (modifier == EwaldModifier::potential_switch) return sw.smoothness;
  return shift != 0 ? 0 : -1;
}

double EwaldRealSpace::self_energy(double sum_q2) const { return -prefactor * beta / std::sqrt(M_PI) * sum_q2; }

std::string EwaldRealSpace::describe(double cutoff) const {
  char buf[200];
  if (modifier == EwaldModifier::potential_switch)
    std::snprintf(buf, sizeof buf,
                  "PME real space C^%d (potential-switch %g-%g nm, switch_smoothness %d; C^%d at the cut-off)",
                  sw.smoothness, sw.r_switch, cutoff, sw.smoothness, sw.smoothness + 1);
  else
    std::snprintf(buf, sizeof buf, "PME real space %s",
                  shift != 0 ? "C^0 (potential-shift: the force jumps at the cut-off, by about ewald_rtol of the bare force)"
                             : "discontinuous (modifier none: the energy jumps at the cut-off)");
  return buf;
}

namespace {

// GROMACS's FFT-friendly sizes: any of the small ones, or a base times a power of two. Of the bases
// grompp tries every one but the first (its loop stops before index 0), and keeps multiples of 4
// other than 140, or 90.
constexpr int kSmallSizes[] = {6, 8, 10, 12, 14, 16, 20, 24, 25, 28, 32, 36, 40, 42, 44};
constexpr int kBaseSizes[] = {45, 48, 50, 52, 54, 56, 60, 64, 70, 72, 75, 80, 81, 84};

int fft_friendly_size(int at_least) {
  for (int n : kSmallSizes)
    if (n >= at_least) return n;
  int power = 1;
  while (power * kBaseSizes[std::size(kBaseSizes) - 1] < at_least) power *= 2;
  int best = 0;
  for (std::size_t k = 1; k < std::size(kBaseSizes); ++k) {
    const int n = power * kBaseSizes[k];
    if (((n % 4 == 0 && n != 140) || n == 90) && n >= at_least && (best == 0 || n < best)) best = n;
  }
  return best;
}

}  // namespace

namespace {

// Physical memory, bytes (0 when unknown: no limit).
double physical_memory() {
  const long pages = sysconf(_SC_PHYS_PAGES), page = sysconf(_SC_PAGE_SIZE);
  return pages > 0 && page > 0 ? double(pages) * page : 0;
}

std::string format_bytes(double bytes) {
  char buf[32];
  const char* units[] = {"bytes", "kB", "MB", "GB", "TB", "PB"};
  int u = 0;
  while (bytes >= 1000 && u < 5) bytes /= 1000, ++u;
  std::snprintf(buf, sizeof buf, u == 0 ? "%.0f %s" : "%.3g %s", bytes, units[u]);
  return buf;
}

}  // namespace

std::string pme_grid_key(const ForceFieldConfig& config) {
  const auto& n = config.fourier_n;
  return n[0] > 0 && n[1] > 0 && n[2] > 0 ? "fourier_nx" : "fourier_spacing";
}

std::array<int, 3> pme_grid_size(const ForceFieldConfig& config, const Box& box) {
  if (!box.periodic())
    throw SettingError("forcefield", "coulomb",
                       "coulomb = \"pme\" needs a box periodic in x, y and z (the structure file's box)");
  const int minimum = 2 * (config.pme_order - 1);
  // In double until the size is known to fit: a tiny spacing or a huge box asks for more points
  // than an int holds.
  std::array<double, 3> wanted{};
  for (int d = 0; d < 3; ++d) {
    const std::string key = std::string("fourier_n") + "xyz"[d];
    if (config.fourier_n[d] > 0) {
      if (config.fourier_n[d] < minimum)
        throw SettingError("forcefield", key,
                           key + " = " + std::to_string(config.fourier_n[d]) + " is too coarse for pme_order " +
                               std::to_string(config.pme_order) + ": the grid needs at least 2 (pme_order - 1) = " +
                               std::to_string(minimum) + " points");
      wanted[d] = config.fourier_n[d];
    } else {
      const double points = std::max(std::floor(box.length[d] / config.fourier_spacing + 0.999), double(minimum));
      wanted[d] = points <= kMaxFourierPoints ? fft_friendly_size(static_cast<int>(points)) : points;
    }
  }
  const std::string key = pme_grid_key(config);
  const bool from_spacing = key == "fourier_spacing";
  const double bytes = ewald_mesh_bytes(wanted, config.pme_order, config.precision == "mixed", omp_get_max_threads());
  const double available = physical_memory();
  const bool too_many = *std::max_element(wanted.begin(), wanted.end()) > kMaxFourierPoints;
  if (too_many || (available > 0 && bytes > available)) {
    char grid[160];
    std::snprintf(grid, sizeof grid, "%.0f x %.0f x %.0f", wanted[0], wanted[1], wanted[2]);
    const std::string cause =
        from_spacing ? "fourier_spacing = " + format_number(config.fourier_spacing) + " nm in a box of " +
                           format_number(box.length[0]) + " x " + format_number(box.length[1]) + " x " +
                           format_number(box.length[2]) + " nm"
                     : "fourier_nx/ny/nz";
    throw SettingError("forcefield", key,
                       cause + " asks for a PME grid of " + grid + " points, which needs " + format_bytes(bytes) +
                           (too_many ? "; at most " + std::to_string(kMaxFourierPoints) + " points along a direction"
                                     : " of memory; this machine has " + format_bytes(available)) +
                           " (a spacing of 0.1-0.16 nm is usual)");
  }
  return {static_cast<int>(wanted[0]), static_cast<int>(wanted[1]), static_cast<int>(wanted[2])};
}

PmeForceErrors pme_force_errors(const ForceFieldConfig& config, const System& system, const Box& box,
                                const std::array<int, 3>& grid) {
  double sum_q2 = 0, sum_q4 = 0;
  int n_charges = 0;
  for (double q : system.charge) {
    sum_q2 += q * q;
    sum_q4 += q * q * q * q;
    n_charges += q != 0;
  }
  if (n_charges == 0) return {0, {0, 0}};
  const EwaldRealSpace e = EwaldRealSpace::from_config(config);
  const double r = ewald_rtol_distance(config);
  return {e.prefactor * 2 * sum_q2 * std::exp(-e.beta * e.beta * r * r) / std::sqrt(n_charges * r * box.volume()),
          ewald_mesh_force_error(box.length, grid, config.pme_order, e.beta, e.prefactor, sum_q2, sum_q4, n_charges)};
}

std::string describe_pme(const ForceFieldConfig& config, const System& system) {
  const Box& box = system.box;
  const EwaldRealSpace e = EwaldRealSpace::from_config(config);
  const std::array<int, 3> n = pme_grid_size(config, box);
  const PmeForceErrors errors = pme_force_errors(config, system, box, n);
  const bool switched = e.modifier == EwaldModifier::potential_switch;
  char buf[600];
  std::snprintf(buf, sizeof buf,
                "beta %.6g nm^-1 (erfc(beta r) = ewald_rtol %g at r = %g nm, %s); grid %d x %d x %d (spacing %.3g x "
                "%.3g x %.3g nm), pme_order %d: the mesh energy is C^%d (forces C^%d); estimated RMS force error "
                "(gmx pme_error's estimate) %.3g kJ/mol/nm in real space, %.3g kJ/mol/nm on the mesh",
                e.beta, config.ewald_rtol, ewald_rtol_distance(config),
                switched ? "the start of the switch: the switch acts where the real space is below it" : "the cut-off",
                n[0], n[1], n[2], box.length[0] / n[0], box.length[1] / n[1], box.length[2] / n[2], config.pme_order,
                config.pme_order - 2, config.pme_order - 3, errors.real_space, errors.mesh.total());
  return buf;
}

}  // namespace vimd
