#pragma once
// Reading a run's inputs: the TOML config, then its .top and .gro, checked against each other.
#include <filesystem>

#include "engine/config.hpp"
#include "engine/state.hpp"
#include "engine/system.hpp"

namespace vimd {

struct RunInput {
  RunConfig config;
  System system;
  State state;  // positions (and velocities) from the .gro; forces not yet computed
  bool velocities_generated = false;  // v empty when the .gro has none and no temperature is set
};

// InputError unless the input has velocities (read or generated): only a run needs them.
void require_velocities(const RunInput& input);

RunInput read_run_input(const std::filesystem::path& config_file);

// Maxwell–Boltzmann velocities at `temperature` with zero total momentum.
Coords maxwell_boltzmann_velocities(const System& system, double temperature, std::uint64_t seed);
// Scales v so that the kinetic temperature (with the system's degrees of freedom) is `temperature`.
void scale_to_temperature(const System& system, double temperature, Coords& v);

}  // namespace vimd
