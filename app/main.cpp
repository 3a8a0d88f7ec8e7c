// vimd: the command line. The wiring from a run config to the simulation loop is app/model.*,
// shared with the Python module (app/python).
#include <malloc.h>
#include <omp.h>
#include <sys/stat.h>

#include <CLI/CLI.hpp>
#include <cerrno>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <stdexcept>
#include <map>
#include <optional>
#include <set>

#include "app/model.hpp"
#include "app/run_schema.hpp"
#include "engine/config_schema.hpp"
#include "engine/errors.hpp"
#include "engine/observers.hpp"
#include "engine/output_lock.hpp"
#include "engine/start_state.hpp"
#include "engine/stop.hpp"
#include "engine/thread_pinning.hpp"
#include "forcefields/nonbonded/ewald.hpp"
#include "forcefields/nonbonded/nonbonded_kernels.hpp"
#include "forcefields/nonbonded/nonbonded_pair_term.hpp"
#include "forcefields/nonbonded/pair_forms.hpp"
#include "forcefields/registry.hpp"
#include "forcefields/settings.hpp"
#include "integrators/registry.hpp"
#include "simd/targets.hpp"
#include "integrators/settings.hpp"

namespace fs = std::filesystem;
using namespace vimd;

namespace {

// The model of a run file, its input warnings printed to stderr.
std::unique_ptr<Model> load_and_warn(const fs::path& config_file) {
  std::unique_ptr<Model> m = load_model(config_file);
  for (const auto& warning : m->input.warnings) std::fprintf(stderr, "vimd: warning: %s\n", warning.c_str());
  return m;
}

// The pair kernels' SIMD target and width, e.g. "AVX2 (4 doubles per vector)".
std::string simd_description() {
  return simd::target_name() + " (" + std::to_string(simd::lanes()) + " doubles per vector)";
}

// Everything a run may leave in its directory.
constexpr const char* kRunFiles[] = {"energy.xvg", "energy.csv", "traj.trr", "confout.gro", "summary.json",
                                     "state.cpt",  "last_good.gro"};

// A directory to write a new run into: creatable, writable, not in use by another run (locked for
// this one), and not holding a finished or stopped run unless `overwrite`. Leftovers of a failed
// run (not resumable) are removed so they cannot pass for this run's output.
OutputLock prepare_output_dir(const fs::path& dir, bool overwrite) {
  std::error_code error;
  fs::create_directories(dir, error);
  if (error || !fs::is_directory(dir)) {
    struct stat st;
    std::string reason = error ? error.message() : "it exists and is not a directory";
    if (::stat(dir.c_str(), &st) != 0 && errno == ENOTDIR)  // e.g. a symbolic link into a regular file
      reason = "part of its path is not a directory";
    else if (::stat(dir.c_str(), &st) == 0 && !S_ISDIR(st.st_mode))
      reason = "it exists and is not a directory";
    throw InputError(dir.string(), 0, "cannot create the output directory: " + reason);
  }
  // A byte written and flushed: fails on a read-only or full file system before any step is spent.
  const fs::path probe = dir / ".vimd-write-test";
  std::FILE* f = std::fopen(probe.c_str(), "w");
  const bool written = f && std::fputs("vimd\n", f) >= 0 && std::fflush(f) == 0;
  const int write_errno = errno;
  if (f) std::fclose(f);
  fs::remove(probe, error);  // never created when the path is too long: the error is the one above
  if (!written)
    throw InputError(dir.string(), 0, std::string("cannot write in the output directory: ") + std::strerror(write_errno));
  OutputLock lock(dir);
  if (!overwrite) {
    if (fs::exists(dir / "summary.json"))
      throw InputError(dir.string(), 0,
                       "already holds a finished run (summary.json); refusing to overwrite it: choose another output "
                       "directory, or pass --overwrite");
    if (fs::exists(dir / "state.cpt"))
      throw InputError(dir.string(), 0,
                       "holds a stopped run (state.cpt): continue it with --continue " + dir.string() +
                           ", or pass --overwrite to start afresh");
  }
  for (const char* name : kRunFiles) {
    fs::remove(dir / name);
    fs::remove(dir / (std::string(name) + ".partial"));
  }
  fs::remove(dir / "state.cpt.new");
  return lock;
}

struct RunOptions {
  std::string out, continue_dir;
  long steps = -1;
  bool overwrite = false;
  bool allow_platform_change = false;
  std::string pinning;  // ThreadPinning::description
};

// The shell command that continues a stopped run: with the thread count and SIMD target it ran
// under, which a bit-identical continue needs (check_platform).
std::string continue_command(const fs::path& config_file, const fs::path& dir, long steps_override) {
  std::string command = "vimd --threads " + std::to_string(omp_get_max_threads()) + " --simd " + simd::target_name() +
                        " run " + fs::absolute(config_file).string() + " --continue " + fs::absolute(dir).string();
  if (steps_override >= 0) command += " --steps " + std::to_string(steps_override);
  return command;
}

// The output directory of the run under way, for the message when it fails.
fs::path run_dir;

// The value of `what` among a platform's facts, or "".
std::string fact(const Platform& platform, const std::string& what) {
  for (const auto& [key, value] : platform)
    if (key == what) return value;
  return "";
}

// A continue must compute as the stopped segment (the last of `segments`) did to be bit-identical:
// under its SIMD target and with its thread count (the threads' shares set the order of the sums),
// unless the user allows the change (which `here`, this segment's platform, then records).
void check_platform(const fs::path& checkpoint_file, const std::vector<RunSegment>& segments, Platform& here,
                    bool allow_change) {
  const Platform stopped = segments.empty() ? Platform{} : segments.back().platform;
  std::string changes, same_as_before;
  auto compare = [&](const std::string& fact_name, const std::string& described, const std::string& option) {
    const std::string before = segments.empty() ? "(not recorded)" : fact(stopped, fact_name);
    const std::string now = fact(here, fact_name);
    if (before == now) return;
    changes += (changes.empty() ? "" : ", ") + described + " " + before + " then, " + now + " now";
    same_as_before += " " + option + " " + before;
  };
  compare("simd_target", "SIMD target", "--simd");
  compare("threads", "threads", "--threads");
  if (changes.empty()) return;
  if (!allow_change)
    throw InputError(checkpoint_file.string(), 0,
                     "the stopped run computed on another platform (" + changes +
                         "): the continued run would not be bit-identical to an uninterrupted one. Continue with" +
                         same_as_before +
                         ", or pass --allow-platform-change to continue anyway (summary.json then records it)");
  here.emplace_back("platform_change", "allowed by --allow-platform-change: " + changes);
}

int run_command(const fs::path& config_file, const RunOptions& options) {
  std::unique_ptr<Model> m = load_and_warn(config_file);
  RunConfig& config = m->input.config;
  if (options.steps >= 0) config.dynamics.steps = options.steps;
  const bool continuing = !options.continue_dir.empty();
  if (continuing && !options.out.empty() && fs::path(options.out) != fs::path(options.continue_dir))
    throw InputError("--continue", 0, "--out " + options.out + " and --continue " + options.continue_dir +
                                          " name different directories (a run continues where it stopped)");
  const fs::path dir = continuing ? fs::path(options.continue_dir)
                                  : options.out.empty() ? config.output.dir : fs::path(options.out);
  const System& system = m->input.system;
  State& state = m->input.state;
  Run run(*m);

  const long steps = config.dynamics.steps;
  const fs::path checkpoint_file = dir / "state.cpt";
  const RunIdentity identity = run_identity(system, config, run_schema(), summary_every(config));
  Platform platform = platform_facts(config);
  platform.emplace_back("pinned", options.pinning);
  Checkpoint checkpoint;
  std::optional<OutputLock> lock;
  if (continuing) {
    if (!fs::is_directory(dir))
      throw InputError(dir.string(), 0, "no such directory: there is no stopped run to continue");
    lock.emplace(dir);
    if (fs::exists(dir / "summary.json"))
      throw InputError(dir.string(), 0, "holds a finished run (summary.json): there is nothing to continue");
    checkpoint = read_checkpoint(checkpoint_file);
    check_identity(checkpoint_file, checkpoint.identity, identity);
    check_platform(checkpoint_file, checkpoint.segments, platform, options.allow_platform_change);
    if (checkpoint.state.step >= checkpoint.first_step + steps) {
      const std::string problem = "the run in " + dir.string() + " stopped at step " +
                                  std::to_string(checkpoint.state.step) + ", which is not before the configured " +
                                  std::to_string(steps) + " steps";
      // Where the steps came from: the command line, or the run file's key (its FILE:LINE).
      if (options.steps >= 0) throw InputError("--steps", 0, problem);
      throw config.locate(SettingError("integrator", "steps", problem));
    }
  } else {
    lock.emplace(prepare_output_dir(dir, options.overwrite));
  }
  std::vector<RunSegment> segments = checkpoint.segments;
  segments.push_back({continuing ? checkpoint.state.step : state.step, platform});

  add_output_observers(run, config, dir, segments);
  run.simulation->add_observer(std::make_unique<ProgressReporter>(stderr));
  run.simulation->on_start_constrained([&](const StartReport& moved) {
    if (moved.position_change > 0)
      std::fprintf(stderr, "vimd: the start is constrained: this moves %s\n",
                   describe_start_change(moved, system).c_str());
  });
  run.simulation->set_checkpoints({checkpoint_file, config.output.checkpoint_every, 900.0, identity, segments});

  const int threads = omp_get_max_threads();
  std::printf("vimd run: %s, %d atoms, %s, dt = %g ps, %ld steps, %d thread%s (pinned: %s), SIMD %s, output in %s\n",
              config.file.string().c_str(), system.n_atoms(), run.integrator->name().c_str(), config.dynamics.dt,
              steps, threads, threads == 1 ? "" : "s", options.pinning.c_str(), simd_description().c_str(),
              dir.string().c_str());
  if (continuing)
    std::printf("vimd run: continuing from step %ld (%s)\n", checkpoint.state.step, checkpoint_file.string().c_str());
  std::fflush(stdout);
  install_stop_handlers();
  run_dir = dir;
  // The integrator checks the system against its settings as it starts.
  const RunTotals totals = config.located([&] {
    return continuing ? run.simulation->resume(checkpoint, checkpoint.first_step + steps, state)
                      : run.simulation->run(state, steps);
  });
  if (totals.stop_signal == 0) return 0;
  const char* name = totals.stop_signal == SIGTERM ? "SIGTERM" : totals.stop_signal == SIGINT ? "SIGINT" : "a signal";
  std::fprintf(stderr,
               "vimd: stopped by %s at step %ld of %ld; the outputs in %s are kept (.partial) with a checkpoint "
               "(state.cpt).\nvimd: continue with: %s\n",
               name, state.step, checkpoint.first_step + steps, dir.string().c_str(),
               continue_command(config.file, dir, options.steps).c_str());
  std::fflush(stderr);
  return 128 + totals.stop_signal;
}

int energy_command(const fs::path& config_file, bool json) {
  std::unique_ptr<Model> m = load_and_warn(config_file);
  Forces forces;
  m->force_field->single_point(m->input.state.q, forces);
  const auto& names = m->force_field->energy_names();
  if (json) {
    std::printf("{");
    for (std::size_t k = 0; k < names.size(); ++k)
      std::printf("\"%s\": %s, ", names[k].c_str(), exact_text(forces.terms[k]).c_str());
    std::printf("\"potential\": %s}\n", exact_text(forces.potential).c_str());
  } else {
    for (std::size_t k = 0; k < names.size(); ++k) std::printf("%-10s %20.10f kJ/mol\n", names[k].c_str(), forces.terms[k]);
    std::printf("%-10s %20.10f kJ/mol\n", "potential", forces.potential);
  }
  return 0;
}

// How smooth the pair interactions are across the cut-off (and switch): a jump in the n-th
// derivative limits the order a variational integrator reaches when pairs cross it.
std::string describe_smoothness(const ForceFieldConfig& ff) {
  std::string text;
  bool coulomb = false;
  for_each_present_form(make_pair_form_constants(ff), [&](const auto& form) {
    text += (text.empty() ? "" : "; ") + form.describe(ff.cutoff);
    coulomb = coulomb || form.kEnergy == PairEnergy::coulomb;
  });
  return coulomb ? text : text + "; no Coulomb";
}

// The pair list as the run will use it (the search skin may be automatic).
std::string describe_pair_list(const ForceField& field) {
  char buf[200];
  for (const auto& term : field.terms())
    if (const auto* pairs = dynamic_cast<const NonbondedPairTerm*>(term.get())) {
      if (pairs->search_skin() > pairs->skin())
        std::snprintf(buf, sizeof buf, "pair list: skin %g nm, pruned from a search with skin %g nm", pairs->skin(),
                      pairs->search_skin());
      else
        std::snprintf(buf, sizeof buf, "pair list: skin %g nm, not pruned", pairs->skin());
      return buf;
    }
  return "no pair list";
}

int check_command(const fs::path& config_file, const std::string& pinning) {
  std::unique_ptr<Model> model = load_and_warn(config_file);
  const Model& m = *model;
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
  std::printf("atoms       %d in %zu molecules; atom types %zu; net charge %.6f e", s.n_atoms(), molecules.size(),
              s.type_names.size(), s.charge.sum());
  if (!s.virtual_sites.empty())
    std::printf("; %zu of the atoms are virtual sites (placed from their atoms)", s.virtual_sites.size());
  std::printf("\n");
  std::printf("box         %.5f x %.5f x %.5f nm", s.box.length[0], s.box.length[1], s.box.length[2]);
  if (volume > 0) std::printf("  (density %.2f kg/m^3)", mass * 1.66053906660 / volume);
  std::printf("\ninteractions %zu bonds, %zu angles, %zu dihedrals, %zu impropers, %zu 1-4 pairs, %zu excluded pairs\n",
              s.bonds.size(), s.angles.size(), s.proper_dihedrals.size() + s.rb_dihedrals.size(),
              s.harmonic_impropers.size() + s.periodic_impropers.size(), s.pairs14.size(), excluded_pairs / 2);
  std::printf("constraints %zu in %zu clusters (largest %zu); %d of them bonds made rigid (constraints = \"%s\")\n",
              s.constraints.size(), m.constraints.clusters().size(), largest_cluster, s.bonds_constrained,
              c.constraints.c_str());
  std::printf("dof         %d\n", s.degrees_of_freedom());
  const bool has_velocities = m.input.state.v.cols() == s.n_atoms();
  std::printf("velocities  %s\n", m.input.velocities_generated ? "generated from [integrator] temperature"
                                   : has_velocities ? "from the structure file"
                                                    : "none in the structure file (a run needs [integrator] temperature)");
  Problem problem{s, *m.force_field, m.constraints, m.inverse_mass};
  State start = m.input.state;
  const StartReport moved = constrain_start(problem, start);
  std::printf("start       %s;\n            here it moves %s", start_state_description(),
              describe_start_change(moved, s).c_str());
  if (has_velocities && !m.input.velocities_generated)
    std::printf(", velocities by up to %.3g nm/ps", moved.velocity_change);
  std::printf("\n");
  const ForceFieldConfig& ff = forcefield_config(c);
  std::printf("forcefield  cutoff %g nm, vdw %s (switch %g nm), coulomb %s (epsilon_rf %g), %s, %s precision; terms:",
              ff.cutoff, ff.vdw_modifier.c_str(), ff.vdw_switch, ff.coulomb.c_str(), ff.epsilon_rf,
              describe_pair_list(*m.force_field).c_str(), ff.precision.c_str());
  for (const auto& name : m.force_field->energy_names()) std::printf(" %s", name.c_str());
  std::printf("\nsmoothness  %s", describe_smoothness(ff).c_str());
  if (ff.coulomb == "pme") std::printf("\npme         %s", describe_pme(ff, s).c_str());
  std::unique_ptr<Integrator> integrator = make_integrator(c);
  std::printf("\nintegrator  %s, dt %g ps, %ld steps (%g ps)\n", integrator->name().c_str(), c.dynamics.dt,
              c.dynamics.steps, c.dynamics.steps * c.dynamics.dt);
  std::printf("output      %s (trajectory every %ld, energies every %ld steps)\n", c.output.dir.string().c_str(),
              c.output.trajectory_every, c.output.energy_every);
  const std::vector<std::string> settings = non_default_settings(c, run_schema());
  for (std::size_t k = 0; k < settings.size(); ++k)
    std::printf("%s%s\n", k == 0 ? "settings    " : "            ", settings[k].c_str());
  std::printf("%severy other key at its default (vimd keys lists them)\n", settings.empty() ? "settings    " : "            ");
  std::string targets;
  for (const auto& t : simd::available_targets()) targets += (targets.empty() ? "" : ", ") + t;
  std::printf("platform    SIMD %s, chosen at run time from %s; %d OpenMP threads, pinned: %s\n",
              simd_description().c_str(), targets.c_str(), omp_get_max_threads(), pinning.c_str());
  return 0;
}

int keys_command(bool markdown) {
  if (markdown) {
    std::fputs(config_reference_markdown(run_schema()).c_str(), stdout);
    return 0;
  }
  const ConfigSchema& schema = run_schema();
  for (const std::string& section : schema.sections()) {
    std::printf("[%s]\n", section.c_str());
    for (const ConfigKey& key : schema.keys) {
      if (key.section != section) continue;
      std::string type = key.type;
      for (std::size_t c = 0; c < key.choices.size(); ++c) type += (c ? " | " : ": ") + key.choices[c];
      std::printf("  %-22s %s; default %s%s\n  %-22s %s\n", key.name.c_str(), type.c_str(),
                  shown_default(key).c_str(),
                  key.on_continue == OnContinue::must_match ? "; must match on --continue" : "", "", key.help.c_str());
    }
  }
  return 0;
}

// "vimd: KIND MESSAGE", always ending its line (the shell prompt must not run on).
void print_error(const char* kind, const std::string& message) {
  const bool ends_line = !message.empty() && message.back() == '\n';
  std::fprintf(stderr, "vimd: %s%s%s", kind, message.c_str(), ends_line ? "" : "\n");
  std::fflush(stderr);
}

}  // namespace

int main(int argc, char** argv) {
  // A fixed threshold: glibc otherwise raises it to the size of each large buffer freed, and the
  // pair lists' regrown buffers then come from the heap, whose freed pages stay resident.
  mallopt(M_MMAP_THRESHOLD, 128 * 1024);
  // A reserve kept at the top of each thread's heap: FFTW allocates and frees a buffer at every
  // transform of the PME mesh, and without the reserve each one is a fresh mapping, its page faults
  // and its unmapping, which stalls every CPU (a TLB shootdown).
  mallopt(M_TOP_PAD, 16 * 1024 * 1024);
  CLI::App app{"vimd: molecular dynamics with RATTLE and variational integrators of any order"};
  app.require_subcommand(1);
  // Options of the program, accepted before or after the subcommand (`vimd run X.toml --threads 2`).
  app.fallthrough();
  int threads = 0;
  app.add_option("--threads", threads, "OpenMP threads (default: OMP_NUM_THREADS or all cores)")
      ->check(CLI::PositiveNumber);
  std::string simd_target;
  app.add_option("--simd", simd_target,
                 "SIMD target of the pair kernels, e.g. AVX2 (default: the best this CPU runs; `vimd check` lists them)");
  std::string pin = "auto";
  app.add_option("--pin", pin,
                 "pin the threads to CPUs: auto (when they use every CPU, as gmx mdrun -pin auto), on, off "
                 "(default: auto; OMP_PROC_BIND, OMP_PLACES or a narrowed CPU set leave them to OpenMP)")
      ->check(CLI::IsMember({"auto", "on", "off"}));

  std::string config;
  RunOptions run_options;
  bool json = false;
  auto* run = app.add_subcommand("run", "run the simulation described by a TOML file");
  run->add_option("config", config, "run parameters (TOML)")->required();
  run->add_option("--out", run_options.out, "output directory (default: [output] dir of the config)");
  run->add_option("--steps", run_options.steps, "number of steps (overrides [integrator] steps)")
      ->check(CLI::NonNegativeNumber);
  auto* continue_option = run->add_option("--continue", run_options.continue_dir,
                  "continue the stopped run in this directory (from its state.cpt) up to the configured steps");
  run->add_flag("--overwrite", run_options.overwrite, "replace a finished or stopped run in the output directory");
  run->add_flag("--allow-platform-change", run_options.allow_platform_change,
                "with --continue: continue under another SIMD target or thread count than the stopped run's (not "
                "bit-identical to an uninterrupted run; summary.json records each segment's)")
      ->needs(continue_option);
  auto* energy = app.add_subcommand("energy", "single-point energy terms of the structure, kJ/mol");
  energy->add_option("config", config, "run parameters (TOML)")->required();
  energy->add_flag("--json", json, "print as JSON");
  auto* check = app.add_subcommand("check", "parse the inputs and describe the system");
  check->add_option("config", config, "run parameters (TOML)")->required();
  bool markdown = false;
  auto* keys = app.add_subcommand("keys", "the run-file keys: type, default, meaning");
  keys->add_flag("--markdown", markdown, "as docs/run-file.md");
  CLI11_PARSE(app, argc, argv);
  if (threads > 0) omp_set_num_threads(threads);
  // `keys` starts no threads, so it has none to pin.
  if (!keys->parsed()) run_options.pinning = pin_threads(parse_pin_mode(pin), omp_get_max_threads()).description;
  // Past a file-size limit, writes should fail with EFBIG (reported as an error), not kill vimd.
  std::signal(SIGXFSZ, SIG_IGN);

  try {
    try {
      if (!simd_target.empty()) simd::use_target(simd_target);
    } catch (const std::invalid_argument& e) {
      throw InputError("--simd", 0, e.what());
    }
    if (run->parsed()) return run_command(config, run_options);
    if (energy->parsed()) return energy_command(config, json);
    if (keys->parsed()) return keys_command(markdown);
    return check_command(config, run_options.pinning);
  } catch (const InputError& e) {
    print_error("input error: ", e.what());
    return 2;
  } catch (const ConvergenceError& e) {
    print_error("", e.what());
    std::string where = "the run stopped";
    if (!run_dir.empty()) {
      where += "; the files ending in .partial in " + run_dir.string() + " hold its output up to its last good step";
      if (fs::exists(run_dir / "last_good.gro")) where += ", " + (run_dir / "last_good.gro").string() + " that step's frame";
    }
    print_error("", where);
    return 3;
  } catch (const std::exception& e) {
    print_error("error: ", e.what());
    return 1;
  }
}
