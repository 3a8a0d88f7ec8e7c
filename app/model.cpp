#include "app/model.hpp"

#include <omp.h>

#include <algorithm>
#include <cstdio>

#include "app/run_schema.hpp"
#include "engine/observers.hpp"
#include "forcefields/input_checks.hpp"
#include "forcefields/registry.hpp"
#include "forcefields/settings.hpp"
#include "integrators/registry.hpp"
#include "integrators/settings.hpp"
#include "simd/targets.hpp"

namespace vimd {

std::unique_ptr<Model> load_model(const std::filesystem::path& config_file, const ConfigOverrides& overrides) {
  auto m = std::make_unique<Model>(
      Model{read_run_input(config_file, run_schema(), overrides, check_force_field_input), nullptr, {}, {}});
  const System& system = m->input.system;
  // A minimiser has no use for velocities: zeros stand in when the structure has none.
  if (m->input.state.v.cols() == 0 && integrator_settings(m->input.config).type == "minimize")
    m->input.state.v = Coords::Zero(3, system.n_atoms());
  const RunConfig& config = m->input.config;
  m->force_field = config.located([&] { return make_force_field(system, forcefield_config(config)); });
  m->constraints = Constraints(system.constraints, system.n_atoms(), system.box);
  m->inverse_mass = system.inverse_mass();
  return m;
}

std::unique_ptr<Integrator> make_integrator(const RunConfig& config) {
  return config.located([&] { return make_integrator(integrator_config(config)); });
}

Run::Run(Model& m)
    : integrator(make_integrator(m.input.config)),
      problem{m.input.system, *m.force_field, m.constraints, m.inverse_mass},
      dt(integrator_settings(m.input.config).type == "minimize" ? 1.0 : m.input.config.dynamics.dt),
      simulation(std::make_unique<Simulation>(problem, *integrator, dt)) {
  m.input.config.located([&] { require_velocities(m.input); });
  if (m.input.velocities_generated) {
    // Generated velocities: remove the constraint components before setting the temperature.
    State& state = m.input.state;
    m.constraints.project_velocities(state.q, state.v, m.inverse_mass);
    scale_to_temperature(m.input.system, *m.input.config.dynamics.temperature, state.v);
  }
}

void Run::restart() { simulation = std::make_unique<Simulation>(problem, *integrator, dt); }

Platform platform_facts(const RunConfig& config) {
  return {{"simd_target", simd::target_name()},
          {"simd_lanes", std::to_string(simd::lanes())},
          {"threads", std::to_string(omp_get_max_threads())},
          {"precision", forcefield_config(config).precision}};
}

long summary_every(const RunConfig& config) {
  const long energy_every = config.output.energy_every;
  // The summary needs a series even when no energy file is written.
  return energy_every > 0 ? energy_every : std::max(1L, config.dynamics.steps / 1000);
}

void add_output_observers(Run& run, const RunConfig& config, const std::filesystem::path& dir,
                          std::vector<RunSegment> segments) {
  const long energy_every = config.output.energy_every;
  Simulation& simulation = *run.simulation;
  if (energy_every > 0) simulation.add_observer(std::make_unique<EnergyWriter>(dir, energy_every));
  if (config.output.trajectory_every > 0)
    simulation.add_observer(std::make_unique<TrajectoryWriter>(dir, config.output.trajectory_every));
  const IntegratorSettings& integrator = integrator_settings(config);
  const bool minimize = integrator.type == "minimize";
  simulation.add_observer(std::make_unique<FinalStructureWriter>(dir, !minimize));
  if (minimize)
    simulation.add_observer(std::make_unique<MinimizationReporter>(dir, integrator.emtol, stdout));
  else
    simulation.add_observer(
        std::make_unique<SummaryReporter>(dir, summary_every(config), stdout, std::move(segments)));
}

}  // namespace vimd
