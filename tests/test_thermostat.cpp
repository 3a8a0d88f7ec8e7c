// The stochastic velocity-rescaling thermostat: its random deviates, the exactness of the
// kinetic-energy update (the canonical distribution is stationary), seeded reproducibility of
// its plain state, canonical sampling with RATTLE and velocity Verlet (mean temperature within
// 1 %, kinetic-energy variance within 10 % of 2⟨K⟩²/N_f), the conserved energy, and the
// integrators that refuse it.
#include <gtest/gtest.h>

#include <random>

#include "engine/errors.hpp"
#include "integrators/rattle.hpp"
#include "integrators/registry.hpp"
#include "integrators/thermostat.hpp"
#include "integrators/verlet.hpp"
#include "tests/constrained_systems.hpp"

namespace vimd {
namespace {

struct Moments {
  double mean = 0, variance = 0;
};
Moments moments(const std::vector<double>& x) {
  Moments m;
  for (double v : x) m.mean += v / x.size();
  for (double v : x) m.variance += (v - m.mean) * (v - m.mean) / x.size();
  return m;
}

void record(const char* name, double value) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.4e", value);
  ::testing::Test::RecordProperty(name, buf);
}

TEST(RandomStream, NormalAndChiSquaredHaveTheirMoments) {
  auto state = RandomStream::seeded(7);
  RandomStream random(state);
  const int draws = 40000;
  std::vector<double> x(draws);
  for (double& v : x) v = random.normal();
  const Moments normal = moments(x);
  EXPECT_NEAR(normal.mean, 0.0, 0.02);
  EXPECT_NEAR(normal.variance, 1.0, 0.03);
  for (int n : {1, 2, 7, 600}) {  // shape < 1, = 1 and > 1 of the underlying gamma
    for (double& v : x) v = random.chi_squared(n);
    const Moments m = moments(x);
    EXPECT_NEAR(m.mean / n, 1.0, 0.03) << n;
    EXPECT_NEAR(m.variance / (2.0 * n), 1.0, 0.1) << n;
  }
  EXPECT_EQ(random.chi_squared(0), 0.0);
}

// The kinetic-energy update alone, iterated as a Markov chain: its stationary law must be the
// canonical one, mean N_f k_B T / 2 and variance 2⟨K⟩²/N_f, for any τ.
TEST(VRescale, KineticEnergyUpdateLeavesTheCanonicalDistributionStationary) {
  const int dof = 50;
  const double temperature = 300, target = 0.5 * dof * kBoltzmann * temperature;
  for (double tau : {0.0, 0.01, 0.5}) {
    VRescaleThermostat thermostat(temperature, tau, 0.002, 3);
    double k = 3 * target;  // start far from equilibrium
    std::vector<double> samples;
    for (int n = 0; n < 400000; ++n) {
      k = thermostat.resample(k, dof);
      if (n >= 2000) samples.push_back(k);
    }
    const Moments m = moments(samples);
    EXPECT_NEAR(m.mean / target, 1.0, 0.01) << "tau " << tau;
    EXPECT_NEAR(m.variance / (2 * target * target / dof), 1.0, 0.05) << "tau " << tau;
  }
}

TEST(VRescale, SeededAndItsPlainStateContinuesTheStream) {
  VRescaleThermostat a(300, 0.1, 0.002, 11), b(300, 0.1, 0.002, 11), c(300, 0.1, 0.002, 12);
  for (int n = 0; n < 10; ++n) EXPECT_EQ(a.resample(100, 30), b.resample(100, 30));
  EXPECT_NE(a.resample(100, 30), c.resample(100, 30));
  const VRescaleState saved = a.state();
  VRescaleThermostat restored(300, 0.1, 0.002, 999);
  restored.set_state(saved);
  for (int n = 0; n < 10; ++n) EXPECT_EQ(a.resample(100, 30), restored.resample(100, 30));
}

IntegratorConfig thermostat_config(const std::string& type, double dt, double tau_t) {
  IntegratorConfig c;
  c.type = type;
  c.dt = dt;
  c.temperature = 300;
  c.thermostat = "v-rescale";
  c.tau_t = tau_t;
  c.seed = 5;
  return c;
}

struct Series {
  std::vector<double> kinetic, total, conserved;
  double dof = 0;
};

// Steps `steps` times after `equilibration` steps, sampling K, K + V and K + V − work every step.
Series sample_run(const System& system, State& state, const std::vector<Bond>& springs, Integrator& integrator,
                  int equilibration,
        int steps) {
  ForceField field;
  field.add(std::make_unique<testing::SpringsAndSoftRepulsion>(system, springs, 2.0, 0.3));
  Constraints constraints(system.constraints, system.n_atoms(), system.box);
  Problem problem{system, field, constraints, system.mass.cwiseInverse()};
  integrator.init(problem, state);
  Series r;
  r.dof = system.degrees_of_freedom();
  for (int n = 0; n < equilibration + steps; ++n) {
    integrator.step(problem, state);
    if (n < equilibration) continue;
    const double k = integrator.kinetic_energy(problem, state);
    r.kinetic.push_back(k);
    r.total.push_back(k + state.potential);
    r.conserved.push_back(k + state.potential - integrator.thermostat_work());
  }
  EXPECT_LT((state.v * system.mass).norm(), 1e-7) << "the rescaling keeps zero momentum (to rounding)";
  return r;
}

void check_canonical(const Series& r, double temperature) {
  const Moments k = moments(r.kinetic);
  const double mean_temperature = 2 * k.mean / (r.dof * kBoltzmann);
  const double canonical_variance = 2 * k.mean * k.mean / r.dof;
  const Moments total = moments(r.total), conserved = moments(r.conserved);
  record("mean_temperature", mean_temperature);
  record("variance_ratio", k.variance / canonical_variance);
  record("total_rms", std::sqrt(total.variance));
  record("conserved_rms", std::sqrt(conserved.variance));
  EXPECT_NEAR(mean_temperature / temperature, 1.0, 0.01);
  EXPECT_NEAR(k.variance / canonical_variance, 1.0, 0.1);
  // The bath moves the total energy by many kJ/mol; the conserved energy only by the integrator's
  // own shadow-energy fluctuation, with no drift between the run's halves.
  EXPECT_LT(std::sqrt(conserved.variance), 0.05 * std::sqrt(total.variance));
  const std::size_t half = r.conserved.size() / 2;
  const Moments first = moments({r.conserved.begin(), r.conserved.begin() + half});
  const Moments second = moments({r.conserved.begin() + half, r.conserved.end()});
  EXPECT_LT(std::abs(second.mean - first.mean), 3 * std::sqrt(conserved.variance));
}

TEST(VRescale, RattleSamplesTheCanonicalKineticEnergy) {
  System system;
  State state;
  testing::water_box(4, 0.31, 9, system, state.q);  // 64 rigid waters, N_f = 381
  state.v = testing::thermal_velocities(system, 200, 10);  // start cold: the bath must heat it
  Rattle rattle(thermostat_config("rattle", 0.002, 0.01));
  const Series r = sample_run(system, state, {}, rattle, 2000, 30000);
  check_canonical(r, 300);
  Constraints constraints(system.constraints, system.n_atoms(), system.box);
  EXPECT_LT(constraints.max_relative_deviation(state.q), 1e-10);
  EXPECT_LT(constraints.max_velocity_residual(state.q, state.v), 1e-10);
}

TEST(VRescale, VelocityVerletSamplesTheCanonicalKineticEnergy) {
  // A 150-bead flexible chain (rigid bonds turned into stiff springs) in a periodic box.
  System system;
  State state;
  std::mt19937_64 rng(23);
  std::vector<Bond> springs;
  system.box.length = Vec3::Constant(3.0);
  testing::add_chain(system, state.q, 150, 0, 0, 0.15, Vec3(1.5, 1.5, 1.5), rng, springs);
  testing::wrap(system.box, state.q);
  for (const Constraint& c : system.constraints) springs.push_back({c.i, c.j, c.length, 5e4});
  system.constraints.clear();
  state.v = testing::thermal_velocities(system, 400, 24);  // start hot
  VelocityVerlet verlet(thermostat_config("verlet", 0.001, 0.01));
  check_canonical(sample_run(system, state, springs, verlet, 2000, 30000), 300);
}

TEST(VRescale, NveIntegratorsRefuseItWithTheReason) {
  for (const char* type : {"vi", "rk", "shake", "minimize"}) {
    try {
      make_integrator(thermostat_config(type, 0.002, 0.1));
      ADD_FAILURE() << type << ": expected InputError";
    } catch (const InputError& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find(std::string("type = \"") + type + "\" cannot use thermostat"), std::string::npos) << what;
    }
  }
  for (const char* type : {"rattle", "verlet"}) EXPECT_NO_THROW(make_integrator(thermostat_config(type, 0.002, 0.1)));
  IntegratorConfig no_temperature = thermostat_config("rattle", 0.002, 0.1);
  no_temperature.temperature.reset();
  EXPECT_THROW(make_integrator(no_temperature), InputError);
}

}  // namespace
}  // namespace vimd
