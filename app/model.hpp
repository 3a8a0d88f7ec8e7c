#pragma once
// The wiring both composition roots share (the vimd program and the Python module): a run file
// (plus settings given next to it) → system, force field and constraints → integrator, problem and
// the simulation loop with the run's output observers. The only place that names concrete force
// terms and integrators together.
#include <filesystem>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "engine/constraints.hpp"
#include "engine/input.hpp"
#include "engine/simulation.hpp"

namespace vimd {

struct Model {
  RunInput input;
  std::unique_ptr<ForceField> force_field;
  Constraints constraints;
  Eigen::VectorXd inverse_mass;
};

// Reads config, topology and structure and builds the force field and constraints. The input's
// warnings are left in input.warnings for the caller to show.
std::unique_ptr<Model> load_model(const std::filesystem::path& config_file, const ConfigOverrides& overrides = {});

// The run file's integrator (its setting errors at their FILE:LINE).
std::unique_ptr<Integrator> make_integrator(const RunConfig& config);

// The integrator and the loop for a model, which must outlive it (they refer into it). InputError
// when the input has no velocities (require_velocities). Velocities generated from the temperature
// get their constraint components removed and are rescaled to it.
struct Run {
  explicit Run(Model& model);
  // A fresh loop (without observers) for a state changed from outside: its first run init()s the
  // integrator again, which constrains the new state and computes its forces.
  void restart();
  std::unique_ptr<Integrator> integrator;
  Problem problem;
  double dt;  // ps; 1 for a minimiser, whose "time" counts steps as GROMACS writes it
  std::unique_ptr<Simulation> simulation;
};

// Facts about where a run runs, for its summary and checkpoints: the pair kernels' SIMD target and
// width, threads, precision.
Platform platform_facts(const RunConfig& config);

// Steps between the samples of the end-of-run summary: the energy output's, else about 1000 in all.
long summary_every(const RunConfig& config);

// The files of a run in dir, which must exist: energies, trajectory, final structure, and the
// end-of-run summary (a minimisation's own for type = "minimize") naming the platform of each of
// the run's `segments`.
void add_output_observers(Run& run, const RunConfig& config, const std::filesystem::path& dir,
                          std::vector<RunSegment> segments = {});

}  // namespace vimd
