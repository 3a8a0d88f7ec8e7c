// vimd: the composition root. Reads a run config, builds the force field, constraints and
// integrator from their registries, and hands them to the one simulation loop.
#include <omp.h>

#include <CLI/CLI.hpp>
#include <cstdio>
#include <filesystem>
#include <map>
#include <set>

#include "engine/constraints.hpp"
#include "engine/errors.hpp"
#include "engine/input.hpp"
#include "engine/observers.hpp"
#include "engine/simulation.hpp"
#include "forcefields/lennard_jones.hpp"
#include "forcefields/reaction_field.hpp"
#include "forcefields/registry.hpp"
#include "integrators/registry.hpp"

namespace fs = std::filesystem;
using namespace vimd;

namespace {

struct Model {
  RunInput input;
  std::unique_ptr<ForceField> force_field;
  Constraints constraints;
  Eigen::VectorXd inverse_mass;
};

Model build_model(const fs::path& config_file) {
  Model m{read_run_input(config_file), nullptr, {}, {}};
  const System& system = m.input.system;
  m.force_field = make_force_field(system, m.input.config.forcefield);
  m.constraints = Constraints(system.constraints, system.n_atoms(), system.box);
  m.inverse_mass = system.mass.cwiseInverse();
  return m;
}

int run_command(const fs::path& config_file, const std::string& out_override, long steps_override) {
  Model m = build_model(config_file);
  RunConfig& config = m.input.config;
  if (steps_override >= 0) config.integrator.steps = steps_override;
  const fs::path dir = out_override.empty() ? config.output.dir : fs::path(out_override);
  const System& system = m.input.system;
  State& state = m.input.state;

  std::unique_ptr<Integrator> integrator = make_integrator(config.integrator);
  Problem problem{system, *m.force_field, m.constraints, m.inverse_mass};
  if (m.input.velocities_generated) {
    // Generated velocities: remove the constraint components before setting the temperature.
    m.constraints.project_velocities(state.q, state.v, m.inverse_mass);
    scale_to_temperature(system, *config.integrator.temperature, state.v);
  }

  fs::create_directories(dir);
  // Outputs of an earlier run in the same place must not pass for this run's.
  for (const char* name : {"energy.xvg", "energy.csv", "traj.trr", "confout.gro", "summary.json"}) {
    fs::remove(dir / name);
    fs::remove(dir / (std::string(name) + ".partial"));
  }

  const long steps = config.integrator.steps;
  const long energy_every = config.output.energy_every;
  // The summary needs a series even when no energy file is written.
  const long summary_every = energy_every > 0 ? energy_every : std::max(1L, steps / 1000);
  Simulation simulation(problem, *integrator, config.integrator.dt);
  if (energy_every > 0) simulation.add_observer(std::make_unique<EnergyWriter>(dir, energy_every));
  if (config.output.trajectory_every > 0)
    simulation.add_observer(std::make_unique<TrajectoryWriter>(dir, config.output.trajectory_every));
  simulation.add_observer(std::make_unique<FinalStructureWriter>(dir));
  simulation.add_observer(std::make_unique<SummaryReporter>(dir, summary_every, stdout));
  simulation.add_observer(std::make_unique<ProgressReporter>(stderr));

  std::printf("vimd run: %s, %d atoms, %s, dt = %g ps, %ld steps, %d threads, output in %s\n",
              config.file.string().c_str(), system.n_atoms(), integrator->name().c_str(), config.integrator.dt, steps,
              omp_get_max_threads(), dir.string().c_str());
  std::fflush(stdout);
  simulation.run(state, steps);
  return 0;
}

std::string json_number(double x) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.17g", x);
  return buf;
}

int energy_command(const fs::path& config_file, bool json) {
  Model m = build_model(config_file);
  Forces forces;
  m.force_field->compute(m.input.state.q, forces);
  const auto& names = m.force_field->energy_names();
  if (json) {
    std::printf("{");
    for (std::size_t k = 0; k < names.size(); ++k)
      std::printf("\"%s\": %s, ", names[k].c_str(), json_number(forces.terms[k]).c_str());
    std::printf("\"potential\": %s}\n", json_number(forces.potential).c_str());
  } else {
    for (std::size_t k = 0; k < names.size(); ++k) std::printf("%-10s %20.10f kJ/mol\n", names[k].c_str(), forces.terms[k]);
    std::printf("%-10s %20.10f kJ/mol\n", "potential", forces.potential);
  }
  return 0;
}

// How smooth the pair interactions are across the cut-off (and switch): a jump in the n-th
// derivative limits the order a variational integrator reaches when pairs cross it.
std::string describe_smoothness(const ForceFieldConfig& ff) {
  auto c_n = [](int n) { return n < 0 ? std::string("discontinuous") : "C^" + std::to_string(n); };
  char buf[160];
  const VdwModifier vdw = parse_vdw_modifier(ff.vdw_modifier);
  std::string lj = "LJ " + c_n(lj_continuity(vdw, ff.switch_smoothness));
  if (vdw == VdwModifier::none) lj += " (the energy jumps at the cut-off)";
  if (vdw == VdwModifier::potential_shift) lj += " (the force jumps at the cut-off)";
  if (vdw == VdwModifier::force_switch) {
    std::snprintf(buf, sizeof buf, " (force-switch %g-%g nm)", ff.vdw_switch, ff.cutoff);
    lj += buf;
  }
  if (vdw == VdwModifier::potential_switch) {
    std::snprintf(buf, sizeof buf, " (potential-switch %g-%g nm, switch_smoothness %d)", ff.vdw_switch, ff.cutoff,
                  ff.switch_smoothness);
    lj += buf;
  }
  const ReactionField rf = make_reaction_field(ff.coulomb, ff.epsilon_r, ff.epsilon_rf, ff.cutoff, ff.coulomb_modifier,
                                               ff.coulomb_switch, ff.switch_smoothness);
  if (rf.kind == CoulombKind::none) return lj + "; no Coulomb";
  const int n = coulomb_continuity(rf, ff.cutoff);
  std::string coulomb = "; Coulomb " + c_n(n);
  if (rf.modifier == CoulombModifier::potential_switch) {
    std::snprintf(buf, sizeof buf, " (potential-switch %g-%g nm, switch_smoothness %d; C^%d at the cut-off)",
                  ff.coulomb_switch, ff.cutoff, n, n + 1);
    coulomb += buf;
  } else {
    coulomb += n == 0 ? " (the force jumps at the cut-off)" : " (eps_rf = inf: the force's slope jumps at the cut-off)";
  }
  return lj + coulomb;
}

int check_command(const fs::path& config_file) {
  Model m = build_model(config_file);
  const RunConfig& c = m.input.config;
  const System& s = m.input.system;
  std::set<int> molecules(s.molecule.begin(), s.molecule.end());
  std::map<std::string, int> residues;
  for (std::size_t i = 0; i < s.residue_names.size(); ++i) residues[s.residue_names[i]]++;
  std::size_t largest_cluster = 0;
  for (const auto& cluster : m.constraints.clusters()) largest_cluster = std::max(largest_cluster, cluster.size());
  std::size_t excluded_pairs = 0;
  for (const auto& e : s.exclusions) excluded_pairs += e.size();
  const double mass = s.mass.sum();
  const double volume = s.box.volume();

  std::printf("config      %s\n", c.file.string().c_str());
  std::printf("structure   %s\ntopology    %s\n", c.structure.string().c_str(), c.topology.string().c_str());
  std::printf("system      %s\n", s.title.c_str());
  std::printf("atoms       %d in %zu molecules; atom types %zu; net charge %.6f e\n", s.n_atoms(), molecules.size(),
              s.type_names.size(), s.charge.sum());
  std::printf("box         %.5f x %.5f x %.5f nm", s.box.length[0], s.box.length[1], s.box.length[2]);
  if (volume > 0) std::printf("  (density %.2f kg/m^3)", mass * 1.66053906660 / volume);
  std::printf("\ninteractions %zu bonds, %zu angles, %zu constraints in %zu clusters (largest %zu), %zu excluded pairs\n",
              s.bonds.size(), s.angles.size(), s.constraints.size(), m.constraints.clusters().size(), largest_cluster,
              excluded_pairs / 2);
  std::printf("dof         %d\n", s.degrees_of_freedom());
  std::printf("velocities  %s\n", m.input.velocities_generated ? "generated from [integrator] temperature" : "from the structure file");
  std::printf("forcefield  cutoff %g nm, vdw %s (switch %g nm), coulomb %s (epsilon_rf %g), skin %g nm; terms:",
              c.forcefield.cutoff, c.forcefield.vdw_modifier.c_str(), c.forcefield.vdw_switch, c.forcefield.coulomb.c_str(),
              c.forcefield.epsilon_rf, c.forcefield.neighbor_skin);
  for (const auto& name : m.force_field->energy_names()) std::printf(" %s", name.c_str());
  std::printf("\nsmoothness  %s", describe_smoothness(c.forcefield).c_str());
  std::unique_ptr<Integrator> integrator = make_integrator(c.integrator);
  std::printf("\nintegrator  %s, dt %g ps, %ld steps (%g ps)\n", integrator->name().c_str(), c.integrator.dt,
              c.integrator.steps, c.integrator.steps * c.integrator.dt);
  std::printf("output      %s (trajectory every %ld, energies every %ld steps)\n", c.output.dir.string().c_str(),
              c.output.trajectory_every, c.output.energy_every);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"vimd: molecular dynamics with RATTLE and variational integrators of any order"};
  app.require_subcommand(1);
  int threads = 0;
  app.add_option("--threads", threads, "OpenMP threads (default: OMP_NUM_THREADS or all cores)");

  std::string config, out;
  long steps = -1;
  bool json = false;
  auto* run = app.add_subcommand("run", "run the simulation described by a TOML file");
  run->add_option("config", config, "run parameters (TOML)")->required();
  run->add_option("--out", out, "output directory (default: [output] dir of the config)");
  run->add_option("--steps", steps, "number of steps (overrides [integrator] steps)")->check(CLI::NonNegativeNumber);
  auto* energy = app.add_subcommand("energy", "single-point energy terms of the structure, kJ/mol");
  energy->add_option("config", config, "run parameters (TOML)")->required();
  energy->add_flag("--json", json, "print as JSON");
  auto* check = app.add_subcommand("check", "parse the inputs and describe the system");
  check->add_option("config", config, "run parameters (TOML)")->required();
  CLI11_PARSE(app, argc, argv);
  if (threads > 0) omp_set_num_threads(threads);

  try {
    if (run->parsed()) return run_command(config, out, steps);
    if (energy->parsed()) return energy_command(config, json);
    return check_command(config);
  } catch (const InputError& e) {
    std::fprintf(stderr, "vimd: input error: %s\n", e.what());
    return 2;
  } catch (const ConvergenceError& e) {
    std::fprintf(stderr, "\nvimd: %s\nvimd: the run stopped; files ending in .partial hold its output up to that point\n",
                 e.what());
    return 3;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "vimd: error: %s\n", e.what());
    return 1;
  }
}
