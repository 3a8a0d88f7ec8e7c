// Energy minimisation with constraints (type = "minimize"): the potential never rises, the
// constraints hold at every step, the descent stops at emtol (or the step limit) through the one
// run loop, and the raw gmx solvate TIP3P box of inputs/tip3p_solvated relaxes to a negative
// nonbonded energy.
#include <gtest/gtest.h>

#include <random>

#include "app/run_schema.hpp"
#include "engine/input.hpp"
#include "engine/simulation.hpp"
#include "forcefields/registry.hpp"
#include "integrators/minimize.hpp"
#include "integrators/registry.hpp"
#include "tests/constrained_systems.hpp"

namespace vimd {
namespace {

// Every sample of a run: potential, constraint deviation, the minimiser's diagnostics.
class Recorder : public Observer {
 public:
  long every() const override { return 1; }
  void observe(const RunInfo& info, const State& state, const Sample& s) override {
    potential.push_back(s.potential);
    deviation.push_back(info.problem.constraints.max_relative_deviation(state.q));
    diagnostics.push_back(s.diagnostics);
  }
  std::vector<double> potential, deviation;
  std::vector<std::vector<double>> diagnostics;
};

// 64 rigid waters on a lattice slightly too tight for the soft repulsion, plus a 6-bead chain
// with springs: a constrained system with a nearby minimum.
struct Waters {
  System system;
  State state;
  ForceField field;
  Constraints constraints;
  std::unique_ptr<Problem> problem;
  Waters() {
    std::mt19937_64 rng(5);
    std::vector<Bond> springs;
    testing::water_box(4, 0.29, 3, system, state.q);
    testing::add_chain(system, state.q, 6, 0, 0, 0.15, Vec3(0.1, 0.1, 0.1), rng, springs);
    testing::wrap(system.box, state.q);
    field.add(std::make_unique<testing::SpringsAndSoftRepulsion>(system, std::move(springs), 2.0, 0.3));
    constraints = Constraints(system.constraints, system.n_atoms(), system.box);
    problem = std::make_unique<Problem>(Problem{system, field, constraints, system.mass.cwiseInverse()});
    state.v = Coords::Zero(3, system.n_atoms());
  }
};

IntegratorConfig minimize_config(double emtol) {
  IntegratorConfig c;
  c.type = "minimize";
  c.emtol = emtol;
  return c;
}

TEST(SteepestDescent, DescendsOnTheConstraintManifoldToEmtol) {
  Waters w;
  const double emtol = 1.0;
  auto integrator = make_integrator(minimize_config(emtol));
  Simulation simulation(*w.problem, *integrator, 1.0);
  auto recorder = std::make_unique<Recorder>();
  Recorder& r = *recorder;
  simulation.add_observer(std::move(recorder));
  const RunTotals totals = simulation.run(w.state, 20000);

  ASSERT_LT(totals.steps, 20000) << "did not converge";
  ASSERT_EQ(r.potential.size(), static_cast<std::size_t>(totals.steps + 1));
  EXPECT_LT(r.potential.back(), r.potential.front() - 1.0);
  for (std::size_t k = 1; k < r.potential.size(); ++k) {
    EXPECT_LE(r.potential[k], r.potential[k - 1]) << "step " << k;
    EXPECT_LT(r.deviation[k], 1e-9) << "step " << k;
  }
  const double max_force = r.diagnostics.back()[0];
  EXPECT_LT(max_force, emtol);
  EXPECT_EQ(max_force, static_cast<SteepestDescent&>(*integrator).max_force());
  // Independently of the minimiser's M⁻¹-weighted projection: at a constrained minimum the force
  // lies in the span of the constraint gradients, so its Euclidean tangent part vanishes too.
  Coords tangent = w.state.f;
  w.constraints.project_velocities(w.state.q, tangent, Eigen::VectorXd::Ones(w.system.n_atoms()));
  EXPECT_LT(tangent.colwise().norm().maxCoeff(), 10 * emtol);
  // ... while the raw force is far from zero (the constraints carry it).
  EXPECT_GT(w.state.f.colwise().norm().maxCoeff(), 10 * emtol);
  EXPECT_EQ(w.state.v.cwiseAbs().maxCoeff(), 0.0);
}

TEST(SteepestDescent, StopsAtTheStepLimitAndWhenAlreadyConverged) {
  Waters w;
  auto integrator = make_integrator(minimize_config(1e-6));
  Simulation simulation(*w.problem, *integrator, 1.0);
  EXPECT_EQ(simulation.run(w.state, 5).steps, 5);
  EXPECT_EQ(w.state.step, 5);

  Waters v;
  auto loose = make_integrator(minimize_config(1e9));  // converged before the first move
  Simulation done(*v.problem, *loose, 1.0);
  const Coords start = [&] {
    loose->init(*v.problem, v.state);
    return v.state.q;
  }();
  EXPECT_EQ(done.run(v.state, 100).steps, 1);
  EXPECT_EQ(v.state.q, start);
}

// The user system: gmx solvate -cs spc216 -box 2.6 2.6 2.6 with amber99sb-ildn TIP3P,
// LJ +1.8e4 kJ/mol before minimisation.
TEST(SteepestDescent, RelaxesTheSolvatedTip3pBox) {
  RunInput in = read_run_input(VIMD_SOURCE_DIR "/inputs/tip3p_solvated/run_min.toml", run_schema());
  in.state.v = Coords::Zero(3, in.system.n_atoms());  // the structure has none; a minimiser needs none
  integrator_settings(in.config).emtol = 1000;
  auto field = make_force_field(in.system, forcefield_config(in.config));
  Forces start;
  field->compute(in.state.q, start);
  const double start_lj = start.terms[0];
  Constraints constraints(in.system.constraints, in.system.n_atoms(), in.system.box);
  Problem problem{in.system, *field, constraints, in.system.mass.cwiseInverse()};
  auto integrator = make_integrator(integrator_config(in.config));
  Simulation simulation(problem, *integrator, 1.0);
  auto recorder = std::make_unique<Recorder>();
  Recorder& r = *recorder;
  simulation.add_observer(std::move(recorder));
  const RunTotals totals = simulation.run(in.state, 2000);

  const auto& names = field->energy_names();
  const auto term = [&](const char* name) {
    return in.state.energy_terms[std::find(names.begin(), names.end(), name) - names.begin()];
  };
  const double max_force = static_cast<SteepestDescent&>(*integrator).max_force();
  ::testing::Test::RecordProperty("steps", std::to_string(totals.steps));
  ::testing::Test::RecordProperty("potential", std::to_string(in.state.potential));
  EXPECT_LT(max_force, 1000.0) << "after " << totals.steps << " steps";
  EXPECT_LT(term("lj") + term("coulomb"), 0.0);
  EXPECT_LT(r.deviation.back(), 1e-9);
  // The overlaps of the raw box are gone: LJ drops from about +1.8e4 kJ/mol to a few thousand.
  ASSERT_EQ(names[0], "lj");
  ::testing::Test::RecordProperty("lj", std::to_string(term("lj")));
  EXPECT_GT(start_lj, 1.5e4);
  EXPECT_LT(term("lj"), 0.5 * start_lj);
  EXPECT_LT(in.state.potential, start.potential - 1e4);
}

}  // namespace
}  // namespace vimd
