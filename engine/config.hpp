#pragma once
// Run parameters from a TOML file. Relative paths are resolved against the config file's
// directory. Unknown keys are an InputError naming the nearest valid key.
#include <array>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <utility>
#include <variant>
#include <vector>

namespace vimd {

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
  int pme_order = 4;                     // B-spline interpolation order
  double fourier_spacing = 0.12;         // nm, largest grid spacing when fourier_n gives no size
  std::array<int, 3> fourier_n = {0, 0, 0};  // fourier_nx, _ny, _nz; 0: from fourier_spacing
  double neighbor_skin = 0.085;                 // nm, buffer of the pair list the kernels run over
  std::optional<double> neighbor_search_skin;   // nm, buffer of the searched list it is pruned from; unset: automatic
  std::string precision = "double";             // "double" | "mixed" (pair forces in single precision)
};

// A user Butcher tableau as given in TOML; checked when the integrator is built.
struct TableauConfig {
  std::vector<std::vector<double>> a;
  std::vector<double> b, c;
  int order = 0;
  int line = 0;  // where it was defined, for error messages
};

struct IntegratorConfig {
  std::string type = "rattle";  // "verlet" | "shake" | "rattle" | "vi" | "rk" | "minimize"
  double dt = 0.002;            // ps
  long steps = 1000;
  double constraint_tolerance = 1e-10;  // relative
  std::optional<double> temperature;    // K: initial velocities when the .gro has none; the thermostat's
  std::uint64_t seed = 1;               // velocity generation and the thermostat's random stream
  std::string thermostat = "none";      // "none" | "v-rescale"
  double tau_t = 0.1;                   // ps, the thermostat's time constant

  // RATTLE as a symmetric composition of its own steps (integrators/composition.hpp).
  std::string composition = "none";          // "none" | a built-in composition | "user"
  std::vector<double> composition_weights;   // composition = "user": the sub-steps γ_k (times dt)
  int composition_order = 0;                 // composition = "user": the order the weights claim

  // Energy minimisation (type = "minimize").
  double emtol = 10.0;   // kJ/mol/nm: stop when the largest constrained force is below this
  double emstep = 0.01;  // nm: the first step's largest displacement

  // Variational / Runge–Kutta integrators.
  std::string method = "rk4";             // tableau name, or "user" with [integrator.tableau]
  std::optional<std::string> method_minus;  // default: same as method
  std::array<double, 2> bias = {0.0, 1.0};  // α⁻, α⁺
  std::string projection = "euclidean";     // "euclidean" | "mass"
  std::optional<double> solver_tolerance;   // default chosen per method by the integrator
  bool solver_tolerance_auto = false;       // "auto": from the last step's truncation-error scale
  int max_iterations = 50;
  std::string acceleration = "none";        // "none" | "anderson"
  std::string solver_precision = "mixed";  // vi: "mixed" | "double" (VariationalSettings::mixed_precision_solve)
  std::optional<TableauConfig> tableau;
};

struct OutputConfig {
  std::filesystem::path dir = "out";
  long trajectory_every = 100;  // steps; 0 disables
  long energy_every = 10;       // steps; 0 disables
  long checkpoint_every = 0;    // steps; 0: every 15 minutes of wall time (and always at the end)
};

struct RunConfig {
  std::filesystem::path file;  // the TOML file itself
  std::filesystem::path structure, topology;
  std::string constraints = "none";  // "none" | "h-bonds" | "all-bonds": bonds made rigid, as GROMACS's mdp option
  ForceFieldConfig forcefield;
  IntegratorConfig integrator;
  OutputConfig output;
};

// Settings given next to the file (e.g. keyword arguments in Python): each key is looked up in the
// tables of the TOML schema and checked exactly as if the file had it; a tableau implies method = "user".
using ConfigValue = std::variant<bool, long, double, std::string, std::vector<double>, TableauConfig>;
using ConfigOverrides = std::vector<std::pair<std::string, ConfigValue>>;

RunConfig read_config(const std::filesystem::path& file, const ConfigOverrides& overrides = {});

}  // namespace vimd
