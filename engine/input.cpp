#include "engine/input.hpp"

#include <random>

#include "engine/errors.hpp"
#include "engine/gro.hpp"
#include "engine/integrator.hpp"
#include "engine/topology.hpp"

namespace vimd {

Coords maxwell_boltzmann_velocities(const System& system, double temperature, std::uint64_t seed) {
  const int n = system.n_atoms();
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  Coords v(3, n);
  for (int i = 0; i < n; ++i)
    for (int k = 0; k < 3; ++k) v(k, i) = normal(rng) * std::sqrt(kBoltzmann * temperature / system.mass[i]);
  const Vec3 momentum = v * system.mass;
  v.colwise() -= momentum / system.mass.sum();
  scale_to_temperature(system, temperature, v);
  return v;
}

void require_velocities(const RunInput& input) {
  if (input.state.v.cols() == input.state.q.cols()) return;
  throw InputError(input.config.file.string(), 0,
                   input.config.structure.string() +
                       " has no velocities: set [integrator] temperature to generate them (a run needs them)");
}

void scale_to_temperature(const System& system, double temperature, Coords& v) {
  const double kinetic = kinetic_energy(system.mass, v);
  const double target = 0.5 * system.degrees_of_freedom() * kBoltzmann * temperature;
  if (kinetic > 0) v *= std::sqrt(target / kinetic);
}

RunInput read_run_input(const std::filesystem::path& config_file) {
  RunInput in;
  in.config = read_config(config_file);
  const RunConfig& c = in.config;
  in.system = read_topology(c.topology);
  GroFrame frame = read_gro(c.structure);

  apply_structure(in.system, frame, c.structure);
  const Box& box = frame.box;
  // Minimum-image pair interactions need the cut-off sphere to fit in half the box.
  if (box.periodic() && 2 * c.forcefield.cutoff > box.length.minCoeff())
    throw InputError(c.file.string(), 0,
                     "cutoff (" + std::to_string(c.forcefield.cutoff) + " nm) exceeds half the smallest box length (" +
                         std::to_string(box.length.minCoeff()) + " nm) of " + c.structure.string());

  in.state.q = frame.x;
  if (frame.v) {
    in.state.v = *frame.v;
  } else if (c.integrator.temperature) {
    in.state.v = maxwell_boltzmann_velocities(in.system, *c.integrator.temperature, c.integrator.seed);
    in.velocities_generated = true;
  }
  return in;
}

}  // namespace vimd
