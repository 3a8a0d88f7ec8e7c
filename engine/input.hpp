#pragma once
// Reading a run's inputs: the TOML config, then its .top and .gro, checked against each other.
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "engine/config.hpp"
#include "engine/state.hpp"
#include "engine/system.hpp"

namespace vimd {

struct RunInput {
  RunConfig config;
  System system;
  State state;  // positions (and velocities) from the .gro; forces not yet computed
  bool velocities_generated = false;  // v empty when the .gro has none and no temperature is set
  // Suspicious but runnable input (as grompp's warnings), each naming its file: the app prints them.
  std::vector<std::string> warnings;
};

// InputError unless the input has velocities (read or generated): only a run needs them.
void require_velocities(const RunInput& input);

// Reads and cross-checks the inputs. Refused (InputError): a box shorter than twice the cut-off,
// atoms closer than 0.05 nm. Warned: a net charge with reaction-field or plain cut-off
// Coulomb, dt above a tenth of the period of the fastest unconstrained bond, atom names that differ
// between structure and topology.
RunInput read_run_input(const std::filesystem::path& config_file, const ConfigOverrides& overrides = {});

// The first pair of atoms (in atom order) nearer than min_distance (minimum image in the periodic
// directions), with the number of such pairs; found through cells, in O(N).
struct Overlap {
  int i, j;  // i < j
  double distance;
  int pairs;
};
std::optional<Overlap> find_overlap(const Coords& x, const Box& box, double min_distance);

// Maxwell–Boltzmann velocities at `temperature` with zero total momentum.
Coords maxwell_boltzmann_velocities(const System& system, double temperature, std::uint64_t seed);
// Scales v so that the kinetic temperature (with the system's degrees of freedom) is `temperature`.
void scale_to_temperature(const System& system, double temperature, Coords& v);

}  // namespace vimd
