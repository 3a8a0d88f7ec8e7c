#pragma once
// Reading a run's inputs: the TOML config, then its .top and .gro, checked against each other.
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "engine/config.hpp"
#include "engine/config_schema.hpp"
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

// A component's settings checked against the system and the structure's box (read at box_line):
// InputError when they cannot work together, else warnings (e.g. the force field's cut-off and net charge).
using InputCheck = std::function<std::vector<std::string>(const RunConfig&, const System&, const Box&, int box_line)>;

// Reads and cross-checks the inputs. Refused (InputError): atoms closer than 0.05 nm, what `check`
// refuses. Warned: what `check` warns of, dt above a tenth of the period of the fastest
// unconstrained bond, atom names that differ between structure and topology.
RunInput read_run_input(const std::filesystem::path& config_file, const ConfigSchema& schema,
                        const ConfigOverrides& overrides = {}, const InputCheck& check = {});

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
