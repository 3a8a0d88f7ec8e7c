// The run loop and its observers: samples, energy files, the end-of-run statistics, and the
// rule that a failed run leaves only ".partial" files.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "engine/errors.hpp"
#include "engine/observers.hpp"
#include "engine/simulation.hpp"

using namespace vimd;
namespace fs = std::filesystem;

namespace {

// Independent harmonic springs to the origin: V = ½ k |q|².
class Springs : public ForceTerm {
 public:
  explicit Springs(double k) : k_(k) {}
  std::vector<std::string> energy_names() const override { return {"springs"}; }
  void add_forces(const Coords& q, Coords& f, std::span<double> e, const TermEvaluation& = {}) override {
    add_single_point(q, f, e);
  }
  void add_single_point(const Coords& q, Coords& f, std::span<double> e) const override {
    f -= k_ * q;
    if (!e.empty()) e[0] += 0.5 * k_ * q.squaredNorm();
  }
  void add_hessian_vector(const Coords&, const Coords& u, Coords& out, const TermEvaluation& = {}) override {
    out += k_ * u;
  }

 private:
  double k_;
};

// Velocity Verlet written out here so the loop is tested without the integrators library.
class TestVerlet : public Integrator {
 public:
  explicit TestVerlet(double dt, long fail_at = -1) : dt_(dt), fail_at_(fail_at) {}
  std::string name() const override { return "test-verlet"; }
  void init(Problem& p, State& s) override { evaluate(p, s); }
  StepReport step(Problem& p, State& s) override {
    if (s.step == fail_at_) throw ConvergenceError("test solver", s.step, 7, 1e-3);
    const Eigen::RowVectorXd w = p.inverse_mass.transpose();
    s.v += 0.5 * dt_ * (s.f.array().rowwise() * w.array()).matrix();
    s.q += dt_ * s.v;
    evaluate(p, s);
    s.v += 0.5 * dt_ * (s.f.array().rowwise() * w.array()).matrix();
    StepReport r;
    r.iterations = 2;
    r.diagnostics = {static_cast<double>(s.step)};
    return r;
  }
  std::vector<std::string> diagnostic_names() const override { return {"probe"}; }

 private:
  void evaluate(Problem& p, State& s) {
    Forces f;
    p.force_field.compute(s.q, f);
    s.f = f.f;
    s.potential = f.potential;
    s.energy_terms = f.terms;
  }
  double dt_;
  long fail_at_;
};

struct Fixture {
  System system;
  ForceField force_field;
  Constraints constraints;
  State state;
  Fixture() {
    const int n = 4;
    system.title = "springs";
    system.mass = Eigen::VectorXd::LinSpaced(n, 1.0, 2.5);
    system.charge = Eigen::VectorXd::Zero(n);
    system.type.assign(n, 0);
    system.atom_names.assign(n, "X");
    system.residue_names.assign(n, "SPR");
    for (int i = 0; i < n; ++i) system.residue_numbers.push_back(i + 1), system.molecule.push_back(i);
    system.exclusions.resize(n);
    force_field.add(std::make_unique<Springs>(50.0));
    state.q = Coords::Random(3, n);
    state.v = Coords::Random(3, n);
  }
  Problem problem() { return Problem{system, force_field, constraints, system.mass.cwiseInverse()}; }
};

std::vector<std::string> lines(const fs::path& p) {
  std::ifstream in(p);
  std::vector<std::string> out;
  for (std::string l; std::getline(in, l);) out.push_back(l);
  return out;
}

}  // namespace

TEST(EnergyStatistics, RecoversSlopeAndFluctuationOfALine) {
  std::vector<double> t, e;
  for (int k = 0; k < 101; ++k) {
    t.push_back(0.1 * k);
    e.push_back(-100.0 + 0.5 * t.back() + (k % 2 ? 0.01 : -0.01));
  }
  const EnergyStatistics s = energy_statistics(t, e, 10);
  EXPECT_NEAR(s.drift, 0.05, 1e-4);  // 0.5 kJ/mol/ps over 10 atoms
  EXPECT_NEAR(s.detrended_fluctuation, 0.01, 1e-3);
  EXPECT_GT(s.rms_fluctuation, 1.0);  // about the mean, the drift dominates
}

TEST(Simulation, WritesEnergySeriesWithTheDocumentedColumns) {
  Fixture fx;
  Problem problem = fx.problem();
  TestVerlet integrator(0.01);
  const fs::path dir = fs::temp_directory_path() / "vimd_test_simulation_ok";
  fs::remove_all(dir);
  fs::create_directories(dir);
  Simulation sim(problem, integrator, 0.01);
  sim.add_observer(std::make_unique<EnergyWriter>(dir, 10));
  std::FILE* sink = std::tmpfile();
  sim.add_observer(std::make_unique<SummaryReporter>(dir, 10, sink));
  const RunTotals totals = sim.run(fx.state, 100);

  EXPECT_EQ(totals.steps, 100);
  EXPECT_EQ(totals.force_evaluations, 101);  // init + one per step
  EXPECT_EQ(fx.state.step, 100);
  EXPECT_NEAR(fx.state.time, 1.0, 1e-12);
  const auto csv = lines(dir / "energy.csv");
  ASSERT_EQ(csv.size(), 1u + 11u);  // header + steps 0, 10, ..., 100
  EXPECT_EQ(csv[0],
            "time,potential,kinetic,total,conserved,temperature,constraint_rms,springs,momentum_x,momentum_y,momentum_z,probe");
  EXPECT_TRUE(fs::exists(dir / "energy.xvg"));
  EXPECT_TRUE(fs::exists(dir / "summary.json"));
  EXPECT_FALSE(fs::exists(dir / "energy.csv.partial"));

  // Verlet on springs at ω dt = 0.07: the total energy in the file stays within 1e-2 relative.
  double e_min = 1e300, e_max = -1e300;
  for (std::size_t k = 1; k < csv.size(); ++k) {
    std::stringstream row(csv[k]);
    std::string cell;
    for (int col = 0; col < 4; ++col) std::getline(row, cell, ',');
    e_min = std::min(e_min, std::stod(cell)), e_max = std::max(e_max, std::stod(cell));
  }
  EXPECT_LT((e_max - e_min) / e_max, 1e-2);
  std::fclose(sink);
}

// The loop asks for energies exactly where a sampling observer is due, for on-step velocities
// where any observer reading them is (the trajectory too), both at the last step; and leaves the
// Problem asking for both after the run.
TEST(Simulation, EnergiesAndVelocitiesAreDueOnlyAtObservedSteps) {
  class DueRecorder : public Observer {
   public:
    DueRecorder(std::vector<long>& due, std::vector<long>& velocities_due) : due_(due), velocities_due_(velocities_due) {}
    long every() const override { return 1; }
    bool needs_sample() const override { return false; }
    void observe(const RunInfo& info, const State& state, const Sample&) override {
      if (state.step == info.first_step) return;
      if (info.problem.energies_due) due_.push_back(state.step);
      if (info.problem.velocities_due) velocities_due_.push_back(state.step);
    }

   private:
    std::vector<long>&due_, &velocities_due_;
  };
  Fixture fx;
  Problem problem = fx.problem();
  TestVerlet integrator(0.01);
  const fs::path dir = fs::temp_directory_path() / "vimd_test_simulation_due";
  fs::remove_all(dir);
  fs::create_directories(dir);
  std::vector<long> due, velocities_due;
  Simulation sim(problem, integrator, 0.01);
  sim.add_observer(std::make_unique<EnergyWriter>(dir, 4));
  sim.add_observer(std::make_unique<TrajectoryWriter>(dir, 5));
  sim.add_observer(std::make_unique<DueRecorder>(due, velocities_due));
  sim.run(fx.state, 14);
  EXPECT_EQ(due, (std::vector<long>{4, 8, 12, 14}));
  EXPECT_EQ(velocities_due, (std::vector<long>{4, 5, 8, 10, 12, 14}));
  EXPECT_TRUE(problem.energies_due);
  EXPECT_TRUE(problem.velocities_due);
}

// A second run() of the same loop continues the state (what Python's sim.step(n) relies on):
// no second init(), and the result equals one run of the summed length.
TEST(Simulation, ASecondRunContinuesWithoutInitialisingAgain) {
  Fixture fx, reference;
  reference.state = fx.state;  // Coords::Random differs per fixture
  Problem problem = fx.problem(), reference_problem = reference.problem();
  TestVerlet integrator(0.01), reference_integrator(0.01);
  Simulation sim(problem, integrator, 0.01), once(reference_problem, reference_integrator, 0.01);
  EXPECT_EQ(sim.run(fx.state, 6).force_evaluations, 7);
  EXPECT_EQ(sim.run(fx.state, 4).force_evaluations, 4);
  once.run(reference.state, 10);
  EXPECT_EQ(fx.state.step, 10);
  EXPECT_EQ(fx.state.q, reference.state.q);
  EXPECT_EQ(fx.state.v, reference.state.v);
}

TEST(Simulation, FailedRunLeavesOnlyPartialFiles) {
  Fixture fx;
  Problem problem = fx.problem();
  TestVerlet integrator(0.01, /*fail_at=*/30);
  const fs::path dir = fs::temp_directory_path() / "vimd_test_simulation_fail";
  fs::remove_all(dir);
  fs::create_directories(dir);
  Simulation sim(problem, integrator, 0.01);
  sim.add_observer(std::make_unique<EnergyWriter>(dir, 10));
  std::FILE* sink = std::tmpfile();
  sim.add_observer(std::make_unique<SummaryReporter>(dir, 10, sink));
  try {
    sim.run(fx.state, 100);
    FAIL() << "the run should have stopped";
  } catch (const ConvergenceError& e) {
    EXPECT_EQ(e.step(), 30);
    EXPECT_EQ(e.iterations(), 7);
    EXPECT_NE(std::string(e.what()).find("step 30"), std::string::npos);
  }
  EXPECT_FALSE(fs::exists(dir / "energy.csv"));
  EXPECT_FALSE(fs::exists(dir / "summary.json"));
  EXPECT_TRUE(fs::exists(dir / "energy.csv.partial"));
  std::fclose(sink);
}

// Verlet on the springs at ω dt ≈ 7 (stable only below 2): amplitudes grow ~50-fold per step.
// The run must stop at the first absurd step, naming the atoms, with no NaN or Inf in any file
// and the last good frame kept as last_good.gro.
TEST(Simulation, BlowUpStopsAtTheStepNamingTheAtoms) {
  Fixture fx;
  fx.system.mass.setOnes();
  Problem problem = fx.problem();
  TestVerlet integrator(1.0);
  const fs::path dir = fs::temp_directory_path() / "vimd_test_simulation_blowup";
  fs::remove_all(dir);
  fs::create_directories(dir);
  Simulation sim(problem, integrator, 1.0);
  sim.add_observer(std::make_unique<EnergyWriter>(dir, 1));
  sim.add_observer(std::make_unique<FinalStructureWriter>(dir));
  long failed_at = -1;
  try {
    sim.run(fx.state, 1000);
    FAIL() << "the run should have blown up";
  } catch (const BlowUpError& e) {
    failed_at = e.step();
    const std::string what = e.what();
    EXPECT_NE(what.find("blew up at step " + std::to_string(e.step())), std::string::npos) << what;
    EXPECT_NE(what.find("atom 1 (X of SPR 1)"), std::string::npos) << what;
  }
  EXPECT_GT(failed_at, 1);
  EXPECT_LT(failed_at, 20);  // |v| passes 1e3 nm/ps within a few steps, long before overflow
  const auto csv = lines(dir / "energy.csv.partial");
  EXPECT_EQ(csv.size(), 1u + failed_at);  // header + steps 0 .. failed_at − 1
  for (const auto& row : csv) {
    EXPECT_EQ(row.find("nan"), std::string::npos) << row;
    EXPECT_EQ(row.find("inf"), std::string::npos) << row;
  }
  EXPECT_FALSE(fs::exists(dir / "energy.csv"));
  ASSERT_TRUE(fs::exists(dir / "last_good.gro"));
  EXPECT_NE(lines(dir / "last_good.gro")[0].find("step " + std::to_string(failed_at - 1)), std::string::npos);
}
