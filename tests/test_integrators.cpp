// The one-step integrators: registry, RATTLE and SHAKE keeping the constraints on a water box and
// on a branched chain, SHAKE ≡ RATTLE in positions, SHAKE's half-step kinetic energy, RATTLE's
// measured order, velocity Verlet's energy conservation, and the errors users meet.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "simd/atom_kernels.hpp"
#include "engine/errors.hpp"
#include "engine/gromacs/gro.hpp"
#include "engine/start_state.hpp"
#include "engine/gromacs/topology.hpp"
#include "forcefields/nonbonded/nonbonded_kernels.hpp"
#include "forcefields/registry.hpp"
#include "integrators/composition.hpp"
#include "integrators/rattle.hpp"
#include "integrators/registry.hpp"
#include "integrators/shake.hpp"
#include "integrators/verlet.hpp"
#include "tests/constrained_systems.hpp"
#include "simd/targets.hpp"

namespace vimd {
namespace {

using testing::SpringsAndSoftRepulsion;

// A system with its potential and constraints; Problem refers into it, so it stays in place
// (hence always held by unique_ptr).
struct TestSystem {
  System system;
  State state;
  std::unique_ptr<ForceField> field;
  Constraints constraints;
  std::unique_ptr<Problem> problem;

  void finish(std::vector<Bond> springs, double epsilon, double cutoff, double temperature, std::uint64_t seed) {
    field = std::make_unique<ForceField>();
    field->add(std::make_unique<SpringsAndSoftRepulsion>(system, std::move(springs), epsilon, cutoff));
    constraints = Constraints(system.constraints, system.n_atoms(), system.box);
    problem = std::make_unique<Problem>(Problem{system, *field, constraints, system.mass.cwiseInverse()});
    state.v = testing::thermal_velocities(system, temperature, seed);
  }
  // What the run loop does before step 0: the engine constrains the start, then the integrator inits.
  void start(Integrator& integrator) {
    constrain_start(*problem, state);
    integrator.init(*problem, state);
  }
};

// 125 rigid waters in a 1.55 nm periodic box (atoms wrapped), positions rounded to 3 decimals
// as in a .gro file, so constraining the start has real work to do.
std::unique_ptr<TestSystem> water_system() {
  auto s = std::make_unique<TestSystem>();
  testing::water_box(5, 0.31, 11, s->system, s->state.q);
  s->state.q = (s->state.q * 1000).array().round() / 1000;
  s->finish({}, 2.0, 0.3, 300, 12);
  return s;
}

// A 150-bead backbone with 4-bead branches every 10 beads (one 199-constraint cluster with
// branch points), in a 3 nm periodic box it is longer than.
std::unique_ptr<TestSystem> polymer_system() {
  auto s = std::make_unique<TestSystem>();
  std::mt19937_64 rng(21);
  std::vector<Bond> springs;
  s->system.box.length = Vec3::Constant(3.0);
  testing::add_chain(s->system, s->state.q, 150, 10, 4, 0.15, Vec3(1.5, 1.5, 1.5), rng, springs);
  testing::wrap(s->system.box, s->state.q);
  s->finish(std::move(springs), 2.0, 0.3, 300, 22);
  return s;
}

// Small and smooth, not periodic: one water, a 5-bead chain (a dense 4-constraint cluster) and
// a diatomic.
std::unique_ptr<TestSystem> small_system() {
  auto s = std::make_unique<TestSystem>();
  std::mt19937_64 rng(31);
  std::vector<Bond> springs;
  testing::add_water(s->system, s->state.q, Vec3(0, 0, 0), rng);
  testing::add_chain(s->system, s->state.q, 5, 0, 0, 0.15, Vec3(0.25, 0, 0), rng, springs);
  testing::add_chain(s->system, s->state.q, 2, 0, 0, 0.12, Vec3(0, 0.25, 0), rng, springs);
  s->finish(std::move(springs), 5.0, 0.35, 300, 32);
  return s;
}

IntegratorConfig config(const std::string& type, double dt, double tolerance = 1e-10,
                        const std::string& composition = "none") {
  IntegratorConfig c;
  c.type = type;
  c.dt = dt;
  c.constraint_tolerance = tolerance;
  c.composition = composition;
  return c;
}

// Slope of the least-squares line through (log x, log y).
double fitted_slope(const std::vector<double>& x, const std::vector<double>& y) {
  const int n = static_cast<int>(x.size());
  double mx = 0, my = 0, sxy = 0, sxx = 0;
  for (int k = 0; k < n; ++k) mx += std::log(x[k]) / n, my += std::log(y[k]) / n;
  for (int k = 0; k < n; ++k)
    sxy += (std::log(x[k]) - mx) * (std::log(y[k]) - my), sxx += (std::log(x[k]) - mx) * (std::log(x[k]) - mx);
  return sxy / sxx;
}

// Measured numbers go into the test report (--gtest_output=xml) for the record.
void record(const char* name, double value) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3e", value);
  ::testing::Test::RecordProperty(name, buf);
}

Vec3 momentum(const TestSystem& s) { return s.state.v * s.system.mass; }

struct EnergyStats {
  double mean_kinetic = 0, fluctuation = 0;  // RMS of the total energy about its mean
};

TEST(IntegratorRegistry, BuildsEveryNamedIntegrator) {
  const auto names = integrator_names();
  for (const char* expected : {"verlet", "shake", "rattle"})
    EXPECT_NE(std::find(names.begin(), names.end(), expected), names.end()) << expected;
  for (const auto& name : names) EXPECT_EQ(make_integrator(config(name, 0.001))->name(), name);
}

TEST(IntegratorRegistry, UnknownTypeListsTheValidOnes) {
  try {
    make_integrator(config("leapfrog", 0.001));
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("leapfrog"), std::string::npos) << what;
    EXPECT_NE(what.find("rattle"), std::string::npos) << what;
  }
}

TEST(IntegratorRegistry, ImpossibleSettingsAreInputErrors) {
  for (const auto& name : integrator_names()) {
    EXPECT_THROW(make_integrator(config(name, 0.0)), InputError) << name;
    EXPECT_THROW(make_integrator(config(name, 0.001, -1e-10)), InputError) << name;
    auto c = config(name, 0.001);
    c.max_iterations = 0;
    EXPECT_THROW(make_integrator(c), InputError) << name;
  }
}

// The engine's start: positions at the mass-weighted closest point (x − y = M⁻¹G(x)ᵀλ, so its
// M-orthogonal tangent part vanishes; one SHAKE projection, with G at y, leaves ~|x − y|/d of it),
// velocities tangent, and nothing moves a second time.
TEST(StartState, ClosestPointOnTheConstraintsAndTangentVelocities) {
  for (auto* make : {&water_system, &polymer_system}) {
    auto s = make();
    s->state.q = (s->state.q * 1000).array().round() / 1000;
    const Coords y = s->state.q;
    ASSERT_GT(s->constraints.max_relative_deviation(y), 1e-5);
    const StartReport report = constrain_start(*s->problem, s->state);
    EXPECT_GE(report.iterations, 2);
    EXPECT_LE(s->constraints.max_relative_deviation(s->state.q), kStartTolerance);
    EXPECT_LE(s->constraints.max_velocity_residual(s->state.q, s->state.v), 1e-12);
    Coords tangential = s->state.q - y;
    const double moved = tangential.cwiseAbs().maxCoeff();
    EXPECT_GT(moved, 1e-5);
    EXPECT_NEAR(report.position_change, tangential.colwise().norm().maxCoeff(), 1e-15);
    s->constraints.project_velocities(s->state.q, tangential, s->problem->inverse_mass);
    record("tangential_part_of_the_move", tangential.cwiseAbs().maxCoeff() / moved);
    EXPECT_LT(tangential.cwiseAbs().maxCoeff(), 1e-9 * moved);

    const State once = s->state;
    constrain_start(*s->problem, s->state);
    EXPECT_LT((s->state.q - once.q).cwiseAbs().maxCoeff(), 1e-14);
    EXPECT_LT((s->state.v - once.v).cwiseAbs().maxCoeff(), 1e-12);
  }
}

// Integrators only step: init() leaves the start exactly as the engine constrained it.
TEST(StartState, InitNeverMovesTheStart) {
  for (const std::string& name : integrator_names()) {
    if (name == "verlet") continue;  // refuses constrained systems (tested below)
    auto s = water_system();
    constrain_start(*s->problem, s->state);
    const State start = s->state;
    auto integrator = make_integrator(config(name, 0.002));
    integrator->init(*s->problem, s->state);
    EXPECT_TRUE(s->state.q == start.q) << name;
    if (name == "minimize")  // a minimisation has no velocities: it zeroes them
      EXPECT_TRUE(s->state.v.isZero()) << name;
    else
      EXPECT_TRUE(s->state.v == start.v) << name;
  }
}

TEST(VelocityVerlet, RefusesConstrainedSystemsAndPointsToRattle) {
  auto s = water_system();
  VelocityVerlet verlet(config("verlet", 0.001));
  try {
    s->start(verlet);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("rattle"), std::string::npos) << e.what();
  }
}

// An unconstrained bead chain with stiff harmonic bonds (period ≈ 75 fs).
std::unique_ptr<TestSystem> flexible_chain_system() {
  auto s = std::make_unique<TestSystem>();
  std::mt19937_64 rng(41);
  std::vector<Bond> springs;
  testing::add_chain(s->system, s->state.q, 40, 0, 0, 0.15, Vec3(0, 0, 0), rng, springs);
  for (const Constraint& c : s->system.constraints) springs.push_back({c.i, c.j, c.length, 5e4});
  s->system.constraints.clear();
  s->finish(std::move(springs), 2.0, 0.3, 300, 42);
  return s;
}

EnergyStats run_and_measure(TestSystem& s, Integrator& integrator, int steps, std::vector<double>* totals = nullptr) {
  s.start(integrator);
  std::vector<double> e;
  double kinetic = 0;
  for (int n = 0; n <= steps; ++n) {
    if (n > 0) integrator.step(*s.problem, s.state);
    const double k = integrator.kinetic_energy(*s.problem, s.state);
    kinetic += k;
    e.push_back(k + s.state.potential);
  }
  double mean = 0, var = 0;
  for (double x : e) mean += x / e.size();
  for (double x : e) var += (x - mean) * (x - mean) / e.size();
  if (totals) *totals = e;
  return {kinetic / e.size(), std::sqrt(var)};
}

TEST(VelocityVerlet, ConservesEnergyWithSecondOrderFluctuations) {
  double fluctuation[2];
  for (int k = 0; k < 2; ++k) {
    auto s = flexible_chain_system();
    const double dt = k == 0 ? 0.001 : 0.0005;
    VelocityVerlet verlet(config("verlet", dt));
    std::vector<double> e;
    const EnergyStats stats = run_and_measure(*s, verlet, static_cast<int>(std::lround(1.0 / dt)), &e);
    fluctuation[k] = stats.fluctuation;
    EXPECT_LT(stats.fluctuation, 1e-2 * stats.mean_kinetic) << "dt " << dt;
    EXPECT_LT(std::abs(e.back() - e.front()), 5 * stats.fluctuation + 1e-9) << "dt " << dt;
  }
  // Halving dt divides the shadow-energy fluctuation by about four.
  record("fluctuation_ratio", fluctuation[0] / fluctuation[1]);
  EXPECT_GT(fluctuation[0] / fluctuation[1], 3.0);
  EXPECT_LT(fluctuation[0] / fluctuation[1], 5.0);
}

TEST(Rattle, WithoutConstraintsIsVelocityVerlet) {
  auto a = flexible_chain_system(), b = flexible_chain_system();
  VelocityVerlet verlet(config("verlet", 0.001));
  Rattle rattle(config("rattle", 0.001));
  a->start(verlet);
  b->start(rattle);
  for (int n = 0; n < 20; ++n) {
    verlet.step(*a->problem, a->state);
    rattle.step(*b->problem, b->state);
  }
  EXPECT_EQ((a->state.q - b->state.q).cwiseAbs().maxCoeff(), 0.0);
  EXPECT_EQ((a->state.v - b->state.v).cwiseAbs().maxCoeff(), 0.0);
}

// RATTLE keeps |g| and |G v| at the tolerance, step after step, and conserves energy and momentum:
// the total energy stays within energy_band × (mean kinetic energy). A composed step reports its
// sub-steps' iterations summed and their largest residual.
void check_rattle_keeps_constraints(TestSystem& s, double dt, int steps, double energy_band = 1e-3,
                                    const std::string& composition = "none") {
  const double tolerance = 1e-10;
  Rattle rattle(config("rattle", dt, tolerance, composition));
  const int sub_steps = resolve_composition(config("rattle", dt, tolerance, composition)).stages();
  ASSERT_GT(s.constraints.max_relative_deviation(s.state.q), 1e-6);  // the start is off the manifold
  s.start(rattle);
  EXPECT_LE(s.constraints.max_relative_deviation(s.state.q), tolerance);
  EXPECT_LE(s.constraints.max_velocity_residual(s.state.q, s.state.v), tolerance);
  const Vec3 p0 = momentum(s);
  const long step0 = s.state.step;
  const double time0 = s.state.time;
  std::vector<double> e;
  double kinetic = 0, worst_g = 0, worst_gv = 0;
  int max_iterations = 0;
  for (int n = 0; n < steps; ++n) {
    const StepReport report = rattle.step(*s.problem, s.state);
    const double deviation = s.constraints.max_relative_deviation(s.state.q);
    if (sub_steps == 1)
      EXPECT_NEAR(report.residual, deviation, 1e-14);  // the report describes the new state
    else
      EXPECT_LE(deviation, report.residual + 1e-14);
    worst_g = std::max(worst_g, deviation);
    worst_gv = std::max(worst_gv, s.constraints.max_velocity_residual(s.state.q, s.state.v));
    EXPECT_LE(report.residual, tolerance);
    EXPECT_GE(report.iterations, sub_steps);
    max_iterations = std::max(max_iterations, report.iterations);
    const double k = rattle.kinetic_energy(*s.problem, s.state);
    kinetic += k / steps;
    e.push_back(k + s.state.potential);
  }
  record("max_deviation", worst_g);
  record("max_velocity_residual", worst_gv);
  record("max_iterations", max_iterations);
  EXPECT_LE(worst_g, tolerance);
  EXPECT_LE(worst_gv, tolerance);
  EXPECT_LE(max_iterations, 10 * sub_steps);
  // The run loop, not the integrator, advances the step counter and the clock.
  EXPECT_EQ(s.state.step, step0);
  EXPECT_EQ(s.state.time, time0);
  // Forces and energies belong to the final positions.
  Forces fresh;
  s.field->compute(s.state.q, fresh);
  EXPECT_LT((fresh.f - s.state.f).cwiseAbs().maxCoeff(), 1e-12 * (1 + fresh.f.cwiseAbs().maxCoeff()));
  EXPECT_DOUBLE_EQ(fresh.potential, s.state.potential);
  // Constraint forces are internal: total momentum is conserved to round-off.
  EXPECT_LT((momentum(s) - p0).norm(), 1e-10 * (1 + s.system.mass.sum()));
  const auto [lo, hi] = std::minmax_element(e.begin(), e.end());
  record("energy_range_over_kinetic", (*hi - *lo) / kinetic);
  EXPECT_LT(*hi - *lo, energy_band * kinetic) << "total energy range vs mean kinetic energy";
}

TEST(Rattle, KeepsConstraintsOnAWaterBox) {
  auto s = water_system();
  check_rattle_keeps_constraints(*s, 0.002, 300);
}

TEST(Rattle, KeepsConstraintsOnABranchedChain) {
  auto s = polymer_system();
  // Knock the start off the manifold as a 3-decimal .gro would.
  s->state.q = (s->state.q * 1000).array().round() / 1000;
  check_rattle_keeps_constraints(*s, 0.004, 300);
}

TEST(ComposedRattle, KeepsConstraintsOnABranchedChain) {
  for (const char* composition : {"yoshida4", "kahan-li8"}) {
    SCOPED_TRACE(composition);
    auto s = polymer_system();
    s->state.q = (s->state.q * 1000).array().round() / 1000;
    check_rattle_keeps_constraints(*s, 0.004, 50, 1e-3, composition);
  }
}

// Velocities are projected only where Problem::velocities_due: between, v keeps a part along the
// constraint gradients, which the next position stage removes. Positions and the velocities seen
// are those of projecting every step (to the constraint tolerance), and looking at a state or not
// changes nothing at all: the steps after an observed one go on from v before its projection.
TEST(Rattle, ProjectsOnlyTheVelocitiesSomeoneSees) {
  const double tolerance = 1e-10;
  const int steps = 40;
  auto every = water_system(), sometimes = water_system(), at_end = water_system();
  Rattle r_every(config("rattle", 0.002, tolerance)), r_sometimes(config("rattle", 0.002, tolerance)),
      r_at_end(config("rattle", 0.002, tolerance));
  every->start(r_every), sometimes->start(r_sometimes), at_end->start(r_at_end);
  double unseen_residual = 0;
  for (int n = 1; n <= steps; ++n) {
    sometimes->problem->velocities_due = n % 7 == 0 || n == steps;
    at_end->problem->velocities_due = n == steps;
    r_every.step(*every->problem, every->state);
    r_sometimes.step(*sometimes->problem, sometimes->state);
    r_at_end.step(*at_end->problem, at_end->state);
    if (n < steps)
      unseen_residual = std::max(unseen_residual, at_end->constraints.max_velocity_residual(at_end->state.q, at_end->state.v));
  }
  EXPECT_GT(unseen_residual, 1e3 * tolerance);  // the projection was skipped
  EXPECT_TRUE(sometimes->state.q == at_end->state.q);
  EXPECT_TRUE(sometimes->state.v == at_end->state.v);
  EXPECT_LE(at_end->constraints.max_velocity_residual(at_end->state.q, at_end->state.v), tolerance);
  EXPECT_LT((at_end->state.q - every->state.q).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_LT((at_end->state.v - every->state.v).cwiseAbs().maxCoeff(), 1e-6 * every->state.v.cwiseAbs().maxCoeff());
}

// Velocities set from outside after an observed step are taken as they are, not the kept ones.
TEST(Rattle, VelocitiesSetAfterAnObservedStepAreTaken) {
  auto kept = water_system(), fresh = water_system();
  Rattle r_kept(config("rattle", 0.002)), r_fresh(config("rattle", 0.002));
  kept->start(r_kept);
  r_kept.step(*kept->problem, kept->state);  // observed: Problem::velocities_due by default
  fresh->state = kept->state;
  kept->state.v *= 0.5;
  fresh->state.v *= 0.5;
  r_fresh.init(*fresh->problem, fresh->state);
  r_kept.step(*kept->problem, kept->state);
  r_fresh.step(*fresh->problem, fresh->state);
  EXPECT_TRUE(kept->state.q == fresh->state.q);
  EXPECT_TRUE(kept->state.v == fresh->state.v);
}

// Each sub-step ends with the force the next one starts from: one force evaluation per sub-step.
TEST(ComposedRattle, OneForceEvaluationPerSubStep) {
  for (const std::string& name : composition_names()) {
    auto s = small_system();
    Rattle rattle(config("rattle", 0.001, 1e-10, name));
    s->start(rattle);
    const long before = s->field->work().force_evaluations;
    for (int n = 0; n < 5; ++n) rattle.step(*s->problem, s->state);
    EXPECT_EQ(s->field->work().force_evaluations - before, 5 * builtin_composition(name).stages()) << name;
  }
}

// A composition of the single weight 1 is plain RATTLE, bit for bit.
TEST(ComposedRattle, TheUnitCompositionIsRattle) {
  auto a = small_system(), b = small_system();
  IntegratorConfig unit = config("rattle", 0.001);
  unit.composition = "user";
  unit.composition_weights = {1.0};
  unit.composition_order = 2;
  Rattle plain(config("rattle", 0.001)), composed(unit);
  a->start(plain);
  b->start(composed);
  for (int n = 0; n < 20; ++n) plain.step(*a->problem, a->state), composed.step(*b->problem, b->state);
  EXPECT_EQ((a->state.q - b->state.q).cwiseAbs().maxCoeff(), 0.0);
  EXPECT_EQ((a->state.v - b->state.v).cwiseAbs().maxCoeff(), 0.0);
}

void check_shake_keeps_constraints(TestSystem& s, double dt, int steps, double energy_band = 1e-3) {
  const double tolerance = 1e-10;
  Shake shake(config("shake", dt, tolerance));
  s.start(shake);
  EXPECT_LE(s.constraints.max_relative_deviation(s.state.q), tolerance);
  std::vector<double> e;
  double kinetic = 0, worst_g = 0;
  for (int n = 0; n < steps; ++n) {
    const StepReport report = shake.step(*s.problem, s.state);
    const double deviation = s.constraints.max_relative_deviation(s.state.q);
    EXPECT_NEAR(report.residual, deviation, 1e-14);
    worst_g = std::max(worst_g, deviation);
    EXPECT_LE(report.residual, tolerance);
    const double k = shake.kinetic_energy(*s.problem, s.state);
    kinetic += k / steps;
    e.push_back(k + s.state.potential);
  }
  EXPECT_LE(worst_g, tolerance);
  const auto [lo, hi] = std::minmax_element(e.begin(), e.end());
  record("energy_range_over_kinetic", (*hi - *lo) / kinetic);
  EXPECT_LT(*hi - *lo, energy_band * kinetic) << "total energy range vs mean kinetic energy";
}

TEST(Shake, KeepsConstraintsOnAWaterBox) {
  auto s = water_system();
  check_shake_keeps_constraints(*s, 0.002, 300);
}

TEST(Shake, KeepsConstraintsOnABranchedChain) {
  auto s = polymer_system();
  check_shake_keeps_constraints(*s, 0.004, 300);
}

// A shipped input (its .gro with velocities) with the real force field.
std::unique_ptr<TestSystem> shipped_system(const std::string& input, const ForceFieldConfig& ff) {
  const std::filesystem::path dir = std::filesystem::path(VIMD_SOURCE_DIR) / "inputs" / input;
  auto s = std::make_unique<TestSystem>();
  s->system = read_topology(dir / "topol.top");
  const GroFrame frame = read_gro(dir / "conf.gro");
  apply_structure(s->system, frame, dir / "conf.gro", dir / "topol.top");
  s->state.q = frame.x;
  s->state.v = frame.v.value();
  s->field = make_force_field(s->system, ff);
  s->constraints = Constraints(s->system.constraints, s->system.n_atoms(), s->system.box);
  s->problem = std::make_unique<Problem>(Problem{s->system, *s->field, s->constraints, s->system.mass.cwiseInverse()});
  return s;
}

// The shipped 216-molecule SPC/E box (3-decimal .gro with velocities) with the real force field
// (reaction field, potential-shift LJ, cut-off 0.9 nm), as its run file sets it up.
std::unique_ptr<TestSystem> spce_system() {
  ForceFieldConfig ff;
  ff.neighbor_skin = 0.03;
  return shipped_system("water216", ff);
}

// 8 rigid SPC/E waters whose pairs all stay far inside the 1.5 nm cut-off (inputs/cluster8): the
// forces are analytic along the trajectory, so a high order shows.
std::unique_ptr<TestSystem> cluster8_system() {
  ForceFieldConfig ff;
  ff.cutoff = 1.5;
  return shipped_system("cluster8", ff);
}

// Measured over 200 steps (the test runs 100): energy range 1.2e-3 (RATTLE) and 2.4e-3 (SHAKE,
// whose half-step averaged kinetic energy fluctuates more, as with GROMACS's leap-frog) of the
// kinetic energy; the RMS fluctuation falls 3.7-fold from 2 to 1 fs: the integrator's, not a drift.
TEST(Rattle, KeepsSpceWaterRigidWithTheRealForceField) {
  auto s = spce_system();
  check_rattle_keeps_constraints(*s, 0.002, 100, 4e-3);
}

TEST(Shake, KeepsSpceWaterRigidWithTheRealForceField) {
  auto s = spce_system();
  check_shake_keeps_constraints(*s, 0.002, 100, 6e-3);
}

// RATTLE's compositions: the global error at 0.1 ps on cluster8 against kahan-li8 at 0.3125 fs
// (its own error there ~10⁸ below kahan-li8's at 3.125 fs), slope ≈ the order. Each set of
// steps divides the end time and keeps the errors above the ~1e-11 nm where round-off takes over.
TEST(ComposedRattle, MeasuredOrders) {
  const double end_time = 0.1, tolerance = 1e-14;
  auto trajectory_end = [&](const std::string& composition, double dt) {
    auto s = cluster8_system();
    Rattle rattle(config("rattle", dt, tolerance, composition));
    s->start(rattle);
    const int steps = static_cast<int>(std::lround(end_time / dt));
    EXPECT_NEAR(steps * dt, end_time, 1e-15) << "every run must end at the same time";
    for (int n = 0; n < steps; ++n) rattle.step(*s->problem, s->state);
    return Coords(s->state.q);
  };
  struct Case {
    std::string composition;
    std::vector<double> dts;
  };
  const std::vector<Case> cases = {{"yoshida4", {0.004, 0.002, 0.001, 0.0005}},
                                   {"suzuki4", {0.004, 0.002, 0.001, 0.0005}},
                                   {"kahan-li6", {0.005, 0.0025, 0.00125}},
                                   {"kahan-li8", {0.00625, 0.005, 0.004, 0.003125}}};
  const Coords reference = trajectory_end("kahan-li8", 0.0003125);
  for (const Case& c : cases) {
    std::vector<double> errors;
    for (double dt : c.dts) errors.push_back((trajectory_end(c.composition, dt) - reference).cwiseAbs().maxCoeff());
    const double slope = fitted_slope(c.dts, errors);
    std::printf("  %s: errors", c.composition.c_str());
    for (double e : errors) std::printf(" %.3e", e);
    std::printf(", order %.2f\n", slope);
    record(("measured_order_" + c.composition).c_str(), slope);
    EXPECT_NEAR(slope, builtin_composition(c.composition).order, 0.3) << c.composition;
    EXPECT_GT(errors.back(), 1e-12) << c.composition << ": too close to round-off to measure an order";
  }
}


// Leap-frog SHAKE and RATTLE generate the same positions when SHAKE starts from
// v_{−1/2} = v_0 − (dt/2) M⁻¹ f_0 (everything along G(q_n)ᵀ is absorbed by the multipliers).
TEST(Shake, TracesTheSamePositionsAsRattle) {
  auto a = water_system(), b = water_system();
  const double dt = 0.002;
  Rattle rattle(config("rattle", dt));
  a->start(rattle);
  b->state = a->state;
  kick(b->problem->inverse_mass, b->state.f, -0.5 * dt, b->state.v);
  Shake shake(config("shake", dt));
  b->start(shake);
  for (int n = 0; n < 50; ++n) {
    rattle.step(*a->problem, a->state);
    shake.step(*b->problem, b->state);
  }
  const double difference = (a->state.q - b->state.q).cwiseAbs().maxCoeff();
  record("max_position_difference", difference);
  EXPECT_LT(difference, 1e-9);
}

TEST(Shake, ReportsTheAverageOfTheHalfStepKineticEnergies) {
  auto s = water_system();
  Shake shake(config("shake", 0.002));
  s->start(shake);
  for (int n = 0; n < 5; ++n) {
    const double reported = shake.kinetic_energy(*s->problem, s->state);
    const double before = kinetic_energy(s->system.mass, s->state.v);  // K(v_{n−1/2})
    shake.step(*s->problem, s->state);
    const double after = kinetic_energy(s->system.mass, s->state.v);  // K(v_{n+1/2})
    EXPECT_NEAR(reported, 0.5 * (before + after), 1e-12 * reported);
    EXPECT_GT(std::abs(before - after), 1e-6 * reported);  // so the check can tell them apart
  }
}

// Asking for the kinetic energy computes the next half step early; it must never change the
// trajectory, and a state modified in between (e.g. by a thermostat) must be stepped as modified.
TEST(Shake, KineticEnergyLookaheadNeverChangesTheTrajectory) {
  std::unique_ptr<TestSystem> s[4];
  std::unique_ptr<Shake> shake[4];
  for (int k = 0; k < 4; ++k) {
    s[k] = water_system();
    shake[k] = std::make_unique<Shake>(config("shake", 0.002));
    s[k]->start(*shake[k]);
  }
  for (int n = 0; n < 10; ++n)
    for (int k = 0; k < 4; ++k) {
      if (k % 2 == 0) shake[k]->kinetic_energy(*s[k]->problem, s[k]->state);  // 0 and 2 look ahead
      if (k >= 2 && n == 4) s[k]->state.v *= 1.001;                           // 2 and 3 are rescaled
      shake[k]->step(*s[k]->problem, s[k]->state);
    }
  for (int k : {0, 2}) {
    EXPECT_EQ((s[k]->state.q - s[k + 1]->state.q).cwiseAbs().maxCoeff(), 0.0) << k;
    EXPECT_EQ((s[k]->state.v - s[k + 1]->state.v).cwiseAbs().maxCoeff(), 0.0) << k;
  }
  EXPECT_GT((s[0]->state.q - s[2]->state.q).cwiseAbs().maxCoeff(), 0.0);
}

// Global error at a fixed time against a much finer run: slope ≈ 2 in log–log.
TEST(Rattle, IsSecondOrder) {
  const double end_time = 0.1, tolerance = 1e-13;
  auto trajectory_end = [&](double dt) {
    auto s = small_system();
    Rattle rattle(config("rattle", dt, tolerance));
    s->start(rattle);
    const int steps = static_cast<int>(std::lround(end_time / dt));
    for (int n = 0; n < steps; ++n) rattle.step(*s->problem, s->state);
    return Coords(s->state.q);
  };
  const Coords reference = trajectory_end(0.002 / 128);
  std::vector<double> dts = {0.002, 0.001, 0.0005, 0.00025}, errors;
  for (double dt : dts) errors.push_back((trajectory_end(dt) - reference).cwiseAbs().maxCoeff());
  const double slope = fitted_slope(dts, errors);
  record("measured_order", slope);
  EXPECT_NEAR(slope, 2.0, 0.3);
}

// On chains: rigid water is solved by SETTLE in one pass, which no iteration limit stops.
TEST(Rattle, NonConvergenceIsAConvergenceErrorNamingTheStep) {
  auto s = polymer_system();
  IntegratorConfig one = config("rattle", 0.002);
  one.max_iterations = 1;
  Rattle rattle(config("rattle", 0.002));
  s->start(rattle);
  s->state.step = 41;
  try {
    Rattle(one).step(*s->problem, s->state);
    FAIL() << "expected ConvergenceError";
  } catch (const ConvergenceError& e) {
    EXPECT_EQ(e.step(), 42);
    EXPECT_EQ(e.iterations(), 1);
    const std::string what = e.what();
    EXPECT_NE(what.find("step 42"), std::string::npos) << what;
    EXPECT_NE(what.find("atoms "), std::string::npos) << what;
  }
}

TEST(Rattle, AbsurdTimeStepIsAConvergenceError) {
  auto s = water_system();
  Rattle rattle(config("rattle", 0.05));  // 25 times a sane step for rigid water
  s->start(rattle);
  EXPECT_THROW(for (int n = 0; n < 20; ++n) rattle.step(*s->problem, s->state), ConvergenceError);
}

TEST(Shake, AbsurdTimeStepIsAConvergenceError) {
  auto s = water_system();
  Shake shake(config("shake", 0.05));
  s->start(shake);
  EXPECT_THROW(for (int n = 0; n < 20; ++n) shake.step(*s->problem, s->state), ConvergenceError);
}

// The per-atom passes on every SIMD target give the bits of plain loops, for a count of atoms that
// leaves a partial vector on every width.
TEST(AtomKernels, EveryTargetGivesTheBitsOfPlainLoops) {
  constexpr int n = 37;
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-2, 2);
  auto random = [&](int size) {
    std::vector<double> x(size);
    for (double& e : x) e = u(rng);
    return x;
  };
  const std::vector<double> w = random(n), f = random(3 * n), v0 = random(3 * n), q0 = random(3 * n);
  const double h = 0.002, hd = 0.004;
  std::vector<double> v_kick = v0, v_ref = v0, q_ref = q0, before_ref(3 * n);
  double largest = 0;
  for (int i = 0; i < n; ++i) {
    const double s = h * w[i];
    for (int k = 0; k < 3; ++k) {
      const int c = 3 * i + k;
      v_kick[c] += s * f[c];
      v_ref[c] += s * f[c];
      before_ref[c] = q_ref[c];
      q_ref[c] += hd * v_ref[c];
    }
    const double dx = q_ref[3 * i] - q0[3 * i], dy = q_ref[3 * i + 1] - q0[3 * i + 1],
                 dz = q_ref[3 * i + 2] - q0[3 * i + 2];
    largest = std::max(largest, dx * dx + dy * dy + dz * dz);
  }
  for (const std::string& target : simd::available_targets()) {
    SCOPED_TRACE(target);
    simd::use_target(target);
    std::vector<double> v = v0;
    simd::kick_kernel()(n, w.data(), h, f.data(), v.data());
    EXPECT_EQ(v, v_kick);
    std::vector<double> q = q0, before(3 * n);
    v = v0;
    simd::kick_drift_kernel()(n, w.data(), h, hd, f.data(), v.data(), q.data(), before.data());
    EXPECT_EQ(v, v_ref);
    EXPECT_EQ(q, q_ref);
    EXPECT_EQ(before, before_ref);
    EXPECT_EQ(simd::max_squared_displacement_kernel()(n, q.data(), q0.data()), largest);
    const WithinNormKernel within = simd::within_norm_kernel();
    std::vector<double> copy(3 * n);
    EXPECT_TRUE(within(n, f.data(), 3.5, copy.data()));  // |f_i| ≤ 2√3
    EXPECT_EQ(copy, f);
    EXPECT_FALSE(within(n, f.data(), 0.5, nullptr));
    for (int atom : {0, n - 1}) {  // in a full vector, and in the partial one
      std::vector<double> with_nan = f;
      with_nan[3 * atom + 1] = std::nan("");
      EXPECT_FALSE(within(n, with_nan.data(), 3.5, nullptr)) << "NaN at atom " << atom;
    }
  }
  simd::use_target("");
}

}  // namespace
}  // namespace vimd
