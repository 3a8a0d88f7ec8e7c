#pragma once
// The integrators' settings ([integrator]): the typed struct each integrator is built from, its keys
// for the run-file schema and the rules between them. The keys every integrator shares and the
// engine uses (dt, steps, constraint_tolerance, temperature, seed) are the engine's DynamicsConfig.
#include <array>
#include <optional>
#include <string>
#include <vector>

#include "engine/config.hpp"
#include "engine/config_schema.hpp"

namespace vimd {

// What the [integrator] keys of the integrators themselves set; held in RunConfig::components.
struct IntegratorSettings {
  std::string type = "rattle";  // "verlet" | "shake" | "rattle" | "vi" | "rk" | "minimize"
  std::string thermostat = "none";  // "none" | "v-rescale"
  double tau_t = 0.1;               // ps, the thermostat's time constant

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

// What an integrator is built from: the shared keys and its own.
struct IntegratorConfig : DynamicsConfig, IntegratorSettings {};

inline const IntegratorSettings& integrator_settings(const RunConfig& c) {
  return c.components.get<IntegratorSettings>();
}
inline IntegratorSettings& integrator_settings(RunConfig& c) { return c.components.get<IntegratorSettings>(); }
inline IntegratorConfig integrator_config(const RunConfig& c) { return {c.dynamics, integrator_settings(c)}; }

// [integrator] type, which the reference lists first.
ConfigKey integrator_type_key();
// The integrators' other keys in the reference's order: the thermostat's, RATTLE's composition,
// the minimiser's, the Runge–Kutta methods' (vi, rk).
std::vector<ConfigKey> integrator_keys();
// The rules between keys that an integrator owns (a thermostat needs a temperature, composition is
// RATTLE's, a user tableau needs method = "user", vi and rk need double-precision forces).
std::vector<ConfigRule> integrator_rules();

}  // namespace vimd
