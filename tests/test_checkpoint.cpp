// Stop and continue: a run stopped at some step and continued from its state.cpt writes
// exactly what the uninterrupted run writes, bit for bit, for RATTLE, SHAKE, the variational
// integrator, RATTLE with the v-rescale thermostat and the minimiser, with 1 and 2 threads, on
// SPC/E water216 (the neighbour list is rebuilt every few steps, so its build positions must be
// part of the checkpoint). Also: a crash between checkpoints (outputs longer than the checkpoint),
// further stop signals while the stop's checkpoint is written, refused checkpoints of another run
// (also of a topology that resolves differently) and damaged ones, and the output directory's lock.
#include <gtest/gtest.h>
#include <omp.h>

#include <unistd.h>

#include <csignal>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>
#include <string>
#include <vector>

#include "app/run_schema.hpp"
#include "engine/checkpoint.hpp"
#include "engine/config_schema.hpp"
#include "engine/errors.hpp"
#include "engine/input.hpp"
#include "engine/observers.hpp"
#include "engine/output_lock.hpp"
#include "engine/simulation.hpp"
#include "engine/stop.hpp"
#include "engine/system_identity.hpp"
#include "forcefields/registry.hpp"
#include "integrators/registry.hpp"

namespace vimd {
namespace {

namespace fs = std::filesystem;

constexpr long kSteps = 24;

// What one process builds from the inputs: everything fresh, as after a restart.
struct Engine {
  RunInput input;
  std::unique_ptr<ForceField> field;
  Constraints constraints;
  Eigen::VectorXd inverse_mass;
  std::unique_ptr<Integrator> integrator;
  std::unique_ptr<Problem> problem;
  std::unique_ptr<Simulation> simulation;

  Engine(const std::string& type, const fs::path& dir, long checkpoint_every) {
    input = read_run_input(fs::path(VIMD_SOURCE_DIR) / "inputs" / "water216" / "run.toml", run_schema());
    IntegratorSettings& settings = integrator_settings(input.config);
    settings.type = type;
    if (type == "rattle_vrescale") {  // the thermostat's random stream and work are carried
      settings.type = "rattle";
      settings.thermostat = "v-rescale";
      input.config.dynamics.temperature = 300.0;
    }
    if (type == "rattle_yoshida4_vrescale") {  // composed steps, with the thermostat once per step
      settings.type = "rattle";
      settings.composition = "yoshida4";
      settings.thermostat = "v-rescale";
      input.config.dynamics.temperature = 300.0;
    }
    if (type.ends_with("_pme")) {  // the mesh keeps grids and its last potential between evaluations
      settings.type = type.substr(0, type.size() - 4);
      forcefield_config(input.config).coulomb = "pme";
      forcefield_config(input.config).pme_order = 6;
    }
    field = make_force_field(input.system, forcefield_config(input.config));
    constraints = Constraints(input.system.constraints, input.system.n_atoms(), input.system.box);
    inverse_mass = input.system.mass.cwiseInverse();
    integrator = make_integrator(integrator_config(input.config));
    problem = std::make_unique<Problem>(Problem{input.system, *field, constraints, inverse_mass});
    simulation = std::make_unique<Simulation>(*problem, *integrator, input.config.dynamics.dt);
    simulation->add_observer(std::make_unique<EnergyWriter>(dir, 1));
    simulation->add_observer(std::make_unique<TrajectoryWriter>(dir, 5));
    simulation->add_observer(std::make_unique<FinalStructureWriter>(dir));
    simulation->add_observer(std::make_unique<SummaryReporter>(dir, 1, sink()));
    simulation->set_checkpoints(
        {dir / "state.cpt", checkpoint_every, 900.0, {{"atoms", "648"}, {"type", type}}, {{0, {{"simd_target", "any"}}}}});
  }
  static std::FILE* sink() {
    static std::FILE* f = std::tmpfile();
    return f;
  }
};

// Asks the run to stop after `step` as SIGTERM would, or throws there (a crash).
class Interrupt : public Observer {
 public:
  Interrupt(long step, bool crash) : step_(step), crash_(crash) {}
  long every() const override { return 1; }
  bool needs_sample() const override { return false; }
  void observe(const RunInfo&, const State& state, const Sample&) override {
    if (state.step != step_) return;
    if (crash_) throw std::runtime_error("simulated crash");
    request_stop(SIGTERM);
  }

 private:
  long step_;
  bool crash_;
};

std::string slurp(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

// summary.json without its wall-time fields (*_seconds, ns_per_day: the only ones that may differ).
std::string deterministic_summary(const fs::path& file) {
  std::istringstream in(slurp(file));
  std::string line, kept;
  while (std::getline(in, line))
    if (line.find("_seconds\"") == std::string::npos && line.find("ns_per_day") == std::string::npos)
      kept += line + "\n";
  return kept;
}

fs::path fresh_dir(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / ("vimd_test_checkpoint_" + name);
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

void expect_same_outputs(const fs::path& a, const fs::path& b, const std::string& what) {
  for (const char* name : {"energy.csv", "energy.xvg", "traj.trr", "confout.gro"}) {
    ASSERT_TRUE(fs::exists(b / name)) << what << ": " << name;
    const std::string x = slurp(a / name), y = slurp(b / name);
    EXPECT_EQ(x.size(), y.size()) << what << ": " << name;
    EXPECT_TRUE(x == y) << what << ": " << name << " differs";
  }
  EXPECT_EQ(deterministic_summary(a / "summary.json"), deterministic_summary(b / "summary.json")) << what;
  EXPECT_EQ(slurp(a / "energy.csv").find("nan,"), std::string::npos);
}

class StopAndContinue : public ::testing::TestWithParam<std::tuple<std::string, int>> {};

TEST_P(StopAndContinue, IsBitIdenticalToTheUninterruptedRun) {
  const auto& [type, threads] = GetParam();
  const int saved_threads = omp_get_max_threads();
  omp_set_num_threads(threads);
  const std::string tag = type + "_" + std::to_string(threads);

  const fs::path whole = fresh_dir(tag + "_whole");
  {
    Engine e(type, whole, 0);
    EXPECT_EQ(e.simulation->run(e.input.state, kSteps).stop_signal, 0);
  }

  const fs::path split = fresh_dir(tag + "_split");
  const long stop_at = 11;
  {
    Engine e(type, split, 0);
    e.simulation->add_observer(std::make_unique<Interrupt>(stop_at, false));
    const RunTotals totals = e.simulation->run(e.input.state, kSteps);
    request_stop(0);
    EXPECT_EQ(totals.stop_signal, SIGTERM);
    EXPECT_EQ(e.input.state.step, stop_at);
    EXPECT_FALSE(fs::exists(split / "energy.csv"));  // outputs stay partial, resumable
    EXPECT_TRUE(fs::exists(split / "energy.csv.partial"));
    EXPECT_TRUE(fs::exists(split / "state.cpt"));
  }
  {
    Engine e(type, split, 0);
    e.simulation->add_observer(std::make_unique<Interrupt>(stop_at, false));  // same observers, same order
    const Checkpoint cp = read_checkpoint(split / "state.cpt");
    EXPECT_EQ(cp.state.step, stop_at);
    EXPECT_EQ(e.simulation->resume(cp, kSteps, e.input.state).stop_signal, 0);
  }
  expect_same_outputs(whole, split, tag);
  omp_set_num_threads(saved_threads);
}

INSTANTIATE_TEST_SUITE_P(Integrators, StopAndContinue,
                         ::testing::Combine(::testing::Values("rattle", "shake", "vi", "rattle_vrescale",
                                                              "rattle_yoshida4_vrescale", "minimize", "rattle_pme",
                                                              "vi_pme"),
                                            ::testing::Values(1, 2)),
                         [](const auto& info) {
                           return std::get<0>(info.param) + "_" + std::to_string(std::get<1>(info.param)) + "threads";
                         });

// A crash after the last checkpoint: the outputs ran on past it; continuing truncates them back
// to the checkpoint and writes those steps again.
TEST(StopAndContinue, AfterACrashBetweenCheckpoints) {
  const fs::path whole = fresh_dir("crash_whole");
  {
    Engine e("vi", whole, 0);
    e.simulation->run(e.input.state, kSteps);
  }
  const fs::path split = fresh_dir("crash_split");
  {
    Engine e("vi", split, 8);
    e.simulation->add_observer(std::make_unique<Interrupt>(13, true));
    EXPECT_THROW(e.simulation->run(e.input.state, kSteps), std::runtime_error);
  }
  EXPECT_TRUE(fs::exists(split / "last_good.gro"));
  {
    Engine e("vi", split, 8);
    e.simulation->add_observer(std::make_unique<Interrupt>(-1, true));  // the restarted process does not crash
    const Checkpoint cp = read_checkpoint(split / "state.cpt");
    EXPECT_EQ(cp.state.step, 8);
    e.simulation->resume(cp, kSteps, e.input.state);
  }
  expect_same_outputs(whole, split, "crash");
}

// Further SIGTERMs while the stop's checkpoint is being written (here: while the observers hand in
// their part), `count` of them.
class SignalsWhileCheckpointing : public Observer {
 public:
  explicit SignalsWhileCheckpointing(int count) : count_(count) {}
  long every() const override { return 0; }
  bool needs_sample() const override { return false; }
  void observe(const RunInfo&, const State&, const Sample&) override {}
  Carried checkpoint(const RunInfo&) override {
    if (stop_signal() != 0)
      for (int k = 0; k < count_; ++k) std::raise(SIGTERM);
    return {};
  }

 private:
  int count_;
};

class RealSignalAt : public Observer {
 public:
  explicit RealSignalAt(long step) : step_(step) {}
  long every() const override { return 1; }
  bool needs_sample() const override { return false; }
  void observe(const RunInfo&, const State& state, const Sample&) override {
    if (state.step == step_) std::raise(SIGTERM);
  }

 private:
  long step_;
};

// A process that installs the stop handlers, gets a real SIGTERM after step 6 and `more` while the
// stop's checkpoint is written; exits 0 if the run stopped there.
void run_with_signals(const fs::path& dir, int more) {
  install_stop_handlers();
  Engine e("rattle", dir, 0);
  e.simulation->add_observer(std::make_unique<RealSignalAt>(6));
  e.simulation->add_observer(std::make_unique<SignalsWhileCheckpointing>(more));
  const bool stopped = e.simulation->run(e.input.state, kSteps).stop_signal == SIGTERM && e.input.state.step == 6;
  std::_Exit(stopped ? 0 : 1);
}

// A second SIGTERM (a scheduler's or a user's impatience) leaves the stop as it was: the checkpoint
// is written, the run can continue. Before, it ended the process, leaving state.cpt.new only.
TEST(StopAndContinue, ASecondSignalLeavesTheStopToFinish) {
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  const fs::path dir = fresh_dir("second_signal");
  EXPECT_EXIT(run_with_signals(dir, 1), ::testing::ExitedWithCode(0),
              "a second SIGTERM: already stopping after this step, with a checkpoint to continue from");
  EXPECT_EQ(read_checkpoint(dir / "state.cpt").state.step, 6);
  EXPECT_FALSE(fs::exists(dir / "state.cpt.new"));
}

// A third ends the process at once, by the signal, saying what is lost.
TEST(StopAndContinue, AThirdSignalEndsAtOnce) {
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  const fs::path dir = fresh_dir("third_signal");
  EXPECT_EXIT(run_with_signals(dir, 2), ::testing::KilledBySignal(SIGTERM),
              "a third SIGTERM: ending now, without the stop's checkpoint");
  EXPECT_FALSE(fs::exists(dir / "state.cpt"));
}

TEST(Checkpoint, IdentityMismatchNamesWhatDiffers) {
  const RunIdentity stored = {{"atoms", "648"}, {"dt", "0.002"}, {"[integrator] type", "vi"}};
  EXPECT_NO_THROW(check_identity("state.cpt", stored, stored));
  try {
    check_identity("state.cpt", stored, {{"atoms", "648"}, {"dt", "0.001"}, {"[integrator] type", "rattle"}});
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("dt: 0.002 in the checkpoint, 0.001 here"), std::string::npos) << what;
    EXPECT_NE(what.find("[integrator] type: vi in the checkpoint, rattle here"), std::string::npos) << what;
    EXPECT_EQ(what.find("atoms"), std::string::npos) << what;
  }
}

// The n-decane melt read with its own nrexcl (3) and with nrexcl 1: the same atoms, bonds and
// parameters, fewer exclusions. A continue across the change is refused, naming the exclusions.
TEST(Checkpoint, IdentityCoversTheResolvedExclusions) {
  const fs::path dir = fresh_dir("nrexcl");
  for (const char* name : {"conf.gro", "topol.top", "decane.itp", "run.toml"})
    fs::copy_file(fs::path(VIMD_SOURCE_DIR) / "inputs" / "alkane" / name, dir / name);
  const RunInput as_shipped = read_run_input(dir / "run.toml", run_schema());
  std::string itp = slurp(dir / "decane.itp");
  const std::size_t at = itp.find("DEC 3\n");
  ASSERT_NE(at, std::string::npos) << "decane.itp's [ moleculetype ] line changed";
  itp.replace(at, 5, "DEC 1");
  std::ofstream(dir / "decane.itp") << itp;
  const RunInput fewer_exclusions = read_run_input(dir / "run.toml", run_schema());
  const RunIdentity stored = run_identity(as_shipped.system, as_shipped.config, run_schema(), 10);
  try {
    check_identity("state.cpt", stored, run_identity(fewer_exclusions.system, fewer_exclusions.config, run_schema(), 10));
    FAIL() << "a continue with nrexcl 1 instead of 3 was accepted";
  } catch (const InputError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("system: exclusions: "), std::string::npos) << what;
    EXPECT_EQ(what.find("system: bonds"), std::string::npos) << what;
  }
}

// Each part of the system, changed alone, changes the identity under its own name.
TEST(Checkpoint, IdentityNamesTheChangedPartOfTheSystem) {
  const RunInput input = read_run_input(fs::path(VIMD_SOURCE_DIR) / "inputs" / "alkane" / "run.toml", run_schema());
  const RunIdentity stored = system_identity(input.system);
  const auto expect_named = [&](const std::string& part, const auto& change) {
    System s = input.system;
    change(s);
    try {
      check_identity("state.cpt", stored, system_identity(s));
      ADD_FAILURE() << part << ": the change was not noticed";
    } catch (const InputError& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find("system: " + part + ": "), std::string::npos) << what;
      EXPECT_EQ(what.find(';'), std::string::npos) << part << ": more than the part changed names: " << what;
    }
  };
  expect_named("masses", [](System& s) { s.mass[7] *= 1.5; });
  expect_named("charges", [](System& s) { std::swap(s.charge[0], s.charge[1]); });
  expect_named("atom types and Lennard-Jones parameters", [](System& s) { s.c12(0, 0) *= 1.0000001; });
  expect_named("bonds", [](System& s) { s.bonds[3].k += 1; });
  expect_named("angles", [](System& s) { s.angles[3].theta0 += 1e-9; });
  expect_named("dihedrals", [](System& s) { s.rb_dihedrals[2].c[5] += 1; });
  expect_named("1-4 pairs", [](System& s) { s.pairs14[5].qq = -s.pairs14[5].qq; });
  expect_named("constraints", [](System& s) { s.constraints.pop_back(); });
  expect_named("exclusions", [](System& s) { std::swap(s.exclusions[0], s.exclusions[1]); });
  expect_named("molecules", [](System& s) { s.molecule.back() += 1; });
  expect_named("atom, residue and type names", [](System& s) { s.residue_names[0] = "XYZ"; });
}

// A checkpoint of n atoms at random positions, velocities and forces, at step 7, its integrator
// carrying the number x = 1.5.
Checkpoint random_checkpoint(int atoms) {
  Checkpoint cp;
  cp.identity = {{"atoms", std::to_string(atoms)}};
  cp.state.q = Coords::Random(3, atoms);
  cp.state.v = Coords::Random(3, atoms);
  cp.state.f = Coords::Random(3, atoms);
  cp.state.step = 7;
  cp.integrator.put("x", 1.5);
  return cp;
}

TEST(Checkpoint, DamagedFilesAreInputErrors) {
  const fs::path dir = fresh_dir("damaged");
  const Checkpoint cp = random_checkpoint(2);
  write_checkpoint(dir / "state.cpt", cp);
  EXPECT_FALSE(fs::exists(dir / "state.cpt.new"));
  const Checkpoint back = read_checkpoint(dir / "state.cpt");
  EXPECT_EQ(back.state.step, 7);
  EXPECT_TRUE(back.state.q == cp.state.q);
  EXPECT_EQ(back.integrator.number("x"), 1.5);

  const std::string bytes = slurp(dir / "state.cpt");
  for (std::size_t keep : {std::size_t{0}, std::size_t{5}, bytes.size() / 2, bytes.size() - 1}) {
    std::ofstream(dir / "cut.cpt", std::ios::binary) << bytes.substr(0, keep);
    EXPECT_THROW(read_checkpoint(dir / "cut.cpt"), InputError) << keep;
  }
  EXPECT_THROW(read_checkpoint(dir / "missing.cpt"), InputError);
}

// Any one bit flipped anywhere (the header, the positions, the checksum itself) is refused, naming
// the file and the checksum; before the checksum, a flip inside an array went unnoticed.
TEST(Checkpoint, AFlippedBitIsRefused) {
  const fs::path dir = fresh_dir("flipped");
  write_checkpoint(dir / "state.cpt", random_checkpoint(5));
  const std::string bytes = slurp(dir / "state.cpt");
  for (std::size_t byte = 0; byte < bytes.size(); byte += 7) {
    std::string damaged = bytes;
    damaged[byte] = static_cast<char>(damaged[byte] ^ (1 << (byte % 8)));
    std::ofstream(dir / "damaged.cpt", std::ios::binary) << damaged;
    try {
      read_checkpoint(dir / "damaged.cpt");
      ADD_FAILURE() << "a bit flipped in byte " << byte << " of " << bytes.size() << " was not noticed";
    } catch (const InputError& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find("damaged.cpt"), std::string::npos) << what;
      if (byte >= 8) {  // past the magic number
        EXPECT_NE(what.find("checksum does not match"), std::string::npos) << what;
      }
    }
  }
}

// Version 1 (no checksum): refused as such, not as damaged.
TEST(Checkpoint, OneWithoutAChecksumIsRefused) {
  const fs::path dir = fresh_dir("version1");
  write_checkpoint(dir / "state.cpt", random_checkpoint(2));
  std::string bytes = slurp(dir / "state.cpt");
  bytes[7] = '1';
  std::ofstream(dir / "old.cpt", std::ios::binary) << bytes.substr(0, bytes.size() - 8);
  try {
    read_checkpoint(dir / "old.cpt");
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("older vimd, without a checksum"), std::string::npos) << e.what();
  }
}

// Each segment's platform comes back: a continue compares the last one's SIMD target with its own.
TEST(Checkpoint, SegmentsComeBack) {
  const fs::path dir = fresh_dir("segments");
  Checkpoint cp = random_checkpoint(2);
  cp.segments = {{0, {{"simd_target", "SSE4"}, {"precision", "double"}}},
                 {400, {{"simd_target", "AVX2"}, {"platform_change", "allowed by --allow-platform-change: SIMD target SSE4 then, AVX2 now"}}}};
  write_checkpoint(dir / "state.cpt", cp);
  const Checkpoint back = read_checkpoint(dir / "state.cpt");
  ASSERT_EQ(back.segments.size(), 2u);
  EXPECT_EQ(back.segments[0].first_step, 0);
  EXPECT_EQ(back.segments[0].platform, cp.segments[0].platform);
  EXPECT_EQ(back.segments[1].first_step, 400);
  EXPECT_EQ(back.segments[1].platform, cp.segments[1].platform);
}

// One run per output directory while it runs; the lock file goes with the run.
TEST(OutputLock, ASecondRunIsRefusedNamingTheHolder) {
  const fs::path dir = fresh_dir("lock");
  {
    const OutputLock first(dir);
    try {
      const OutputLock second(dir);
      FAIL() << "a second lock on the same directory was granted";
    } catch (const InputError& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find("another vimd run is writing into this directory (pid " + std::to_string(::getpid()) +
                          " on host "),
                std::string::npos)
          << what;
      EXPECT_NE(what.find(", started 20"), std::string::npos) << what;
    }
  }
  EXPECT_FALSE(fs::exists(dir / ".vimd.lock"));
  EXPECT_NO_THROW(OutputLock again(dir));
}

// Arrays far larger than the writer's buffer, between small fields: every one comes back exactly.
TEST(Checkpoint, LargeArraysComeBackExactly) {
  const fs::path dir = fresh_dir("large");
  Checkpoint cp = random_checkpoint(30000);
  cp.state.energy_terms = {1.0, 2.0};
  cp.integrator.put("history", std::vector<double>(50000, 0.25));
  cp.force_field.put("built_at", Coords::Random(3, 30000));
  cp.observers.resize(2);
  cp.observers[1].put("series", std::vector<double>(9000, -3.0));
  write_checkpoint(dir / "state.cpt", cp);
  const Checkpoint back = read_checkpoint(dir / "state.cpt");
  EXPECT_TRUE(back.state.q == cp.state.q);
  EXPECT_TRUE(back.state.v == cp.state.v);
  EXPECT_TRUE(back.state.f == cp.state.f);
  EXPECT_EQ(back.state.energy_terms, cp.state.energy_terms);
  EXPECT_EQ(back.integrator.values("history"), cp.integrator.values("history"));
  EXPECT_EQ(back.integrator.number("x"), 1.5);
  EXPECT_TRUE(back.force_field.coords("built_at") == cp.force_field.coords("built_at"));
  ASSERT_EQ(back.observers.size(), 2u);
  EXPECT_TRUE(back.observers[0].empty());
  EXPECT_EQ(back.observers[1].values("series"), cp.observers[1].values("series"));
}

}  // namespace
}  // namespace vimd
