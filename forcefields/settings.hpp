#pragma once
// The force field's settings ([forcefield]): the typed struct the terms are built from, its keys
// for the run-file schema and the rules between them. Held in RunConfig::components.
#include <array>
#include <optional>
#include <string>
#include <vector>

#include "engine/config.hpp"
#include "engine/config_schema.hpp"
#include "forcefields/bspline.hpp"

namespace vimd {

// PME's B-spline interpolation orders (pme_order), the one range the run file and the mesh accept.
constexpr int kMinPmeOrder = 4;
constexpr int kMaxPmeOrder = kMaxSplineOrder;
// The most PME grid points along one direction, given (fourier_nx) or from fourier_spacing: 4096³
// points would already take terabytes.
constexpr int kMaxFourierPoints = 4096;

struct ForceFieldConfig {
  double cutoff = 0.9;                          // nm, rvdw = rcoulomb
  std::string vdw_modifier = "potential-shift"; // "none" | "potential-shift" | "force-switch" | "potential-switch"
  double vdw_switch = 0.0;                      // nm, start of the switch region
  std::string coulomb = "reaction-field";       // "reaction-field" | "cutoff" | "pme" | "none"
  std::string coulomb_modifier = "potential-shift";  // "none" | "potential-shift" | "potential-switch"
  double coulomb_switch = 0.0;                  // nm, start of the Coulomb switch region
  int switch_smoothness = 2;                    // k: potential-switch pair potentials are C^k (2 = GROMACS)
  double epsilon_r = 1.0;
  double epsilon_rf = 0.0;                      // 0 means infinity
  // PME (coulomb = "pme"), as GROMACS's mdp options of the same names.
  double ewald_rtol = 1e-5;              // erfc(β r) at the cut-off (or at coulomb_switch when switched)
  int pme_order = 4;                     // B-spline interpolation order, kMinPmeOrder..kMaxPmeOrder
  double fourier_spacing = 0.12;         // nm, largest grid spacing when fourier_n gives no size
  std::array<int, 3> fourier_n = {0, 0, 0};  // fourier_nx, _ny, _nz; 0: from fourier_spacing
  double neighbor_skin = 0.085;                 // nm, buffer of the pair list the kernels run over
  std::optional<double> neighbor_search_skin;   // nm, buffer of the searched list it is pruned from; unset: automatic
  std::string precision = "double";             // "double" | "mixed" (pair forces in single precision)
};

inline const ForceFieldConfig& forcefield_config(const RunConfig& c) { return c.components.get<ForceFieldConfig>(); }
inline ForceFieldConfig& forcefield_config(RunConfig& c) { return c.components.get<ForceFieldConfig>(); }

// The [forcefield] keys in the reference's order: the pair forms (cut-off, LJ and Coulomb), PME's,
// the pair list's, the precision.
std::vector<ConfigKey> forcefield_keys();
// The rules between them (switches inside the cut-off, the search skin over the skin).
std::vector<ConfigRule> forcefield_rules();

}  // namespace vimd
