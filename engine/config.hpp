#pragma once
// Run parameters from a TOML file. Relative paths are resolved against the config file's
// directory. Unknown keys are an InputError naming the nearest valid key. The keys themselves
// come from a ConfigSchema (engine/config_schema.hpp): the engine's own, and each component's.
#include <any>
#include <cstdint>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <typeindex>
#include <utility>
#include <variant>
#include <vector>

#include "engine/errors.hpp"

namespace vimd {

// A user Butcher tableau as given in TOML; checked when the integrator is built.
struct TableauConfig {
  std::vector<std::vector<double>> a;
  std::vector<double> b, c;
  int order = 0;
  int line = 0;  // where it was defined, for error messages
};

// The [integrator] keys every integrator shares and the engine itself uses (velocity generation,
// the time-step warning, the run's length).
struct DynamicsConfig {
  double dt = 0.002;  // ps
  long steps = 1000;
  double constraint_tolerance = 1e-10;  // relative
  std::optional<double> temperature;    // K: initial velocities when the .gro has none; the thermostat's
  std::uint64_t seed = 1;               // velocity generation and the thermostat's random stream
};

struct OutputConfig {
  std::filesystem::path dir = "out";
  long trajectory_every = 100;  // steps; 0 disables
  long energy_every = 10;       // steps; 0 disables
  long checkpoint_every = 0;    // steps; 0: every 15 minutes of wall time (and always at the end)
};

// Each component's settings (the force field's, the integrators'), held by their type: the engine
// reads, copies and stores them without knowing them. A type not stored yet reads as its defaults.
class ComponentSettings {
 public:
  template <class T>
  const T& get() const {
    if (const auto it = blocks_.find(typeid(T)); it != blocks_.end()) return std::any_cast<const T&>(it->second);
    static const T defaults{};
    return defaults;
  }
  template <class T>
  T& get() {
    const auto it = blocks_.try_emplace(typeid(T), std::in_place_type<T>).first;
    return std::any_cast<T&>(it->second);
  }

 private:
  std::map<std::type_index, std::any> blocks_;
};

// Where the run file gave each key and table, for the errors found after reading
// (RunConfig::locate).
struct SettingSources {
  // 0: given next to the file (ConfigOverrides), which has no line.
  std::map<std::pair<std::string, std::string>, int> key_lines;  // (section, key)
  std::map<std::string, int> table_lines;                         // section
};

struct RunConfig {
  std::filesystem::path file;  // the TOML file itself
  std::filesystem::path structure, topology;
  std::string constraints = "none";  // "none" | "h-bonds" | "all-bonds": bonds made rigid, as GROMACS's mdp option
  DynamicsConfig dynamics;
  OutputConfig output;
  ComponentSettings components;
  SettingSources sources;

  // The error at the FILE:LINE of the key (of its table when the key was left at its default; the
  // file when neither is in it), or naming the settings given next to the file.
  InputError locate(const SettingError& e) const;
  // f(), with a SettingError it throws located: the one place run-file settings checked after
  // reading get their FILE:LINE.
  template <class F>
  decltype(auto) located(F&& f) const;
};

// Settings given next to the file (e.g. keyword arguments in Python): each key is looked up in the
// tables of the TOML schema and checked exactly as if the file had it; a tableau implies method = "user".
template <class F>
decltype(auto) RunConfig::located(F&& f) const {
  try {
    return f();
  } catch (const SettingError& e) {
    throw locate(e);
  }
}

using ConfigValue = std::variant<bool, long, double, std::string, std::vector<double>, TableauConfig>;
using ConfigOverrides = std::vector<std::pair<std::string, ConfigValue>>;

struct ConfigSchema;
RunConfig read_config(const std::filesystem::path& file, const ConfigSchema& schema,
                      const ConfigOverrides& overrides = {});

}  // namespace vimd
