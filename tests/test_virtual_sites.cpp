// Virtual sites: every construction's forces and Hessian–vector products against finite
// differences (random and near-degenerate geometry, a site built from a site), the sites'
// velocities, and rigid TIP4P/2005 water under RATTLE and the variational integrator.
#include <gtest/gtest.h>

#include <filesystem>

#include "derivative_checks.hpp"
#include "app/run_schema.hpp"
#include "engine/config_schema.hpp"
#include "engine/constraints.hpp"
#include "engine/gromacs/topology.hpp"
#include "engine/integrator.hpp"
#include "engine/simulation.hpp"
#include "forcefields/registry.hpp"
#include "integrators/registry.hpp"

using namespace vimd;
namespace vt = vimd::testing;
using vt::expect_derivatives_match;
using Kind = VirtualSite::Kind;

namespace {

const std::filesystem::path kTop = std::filesystem::path(VIMD_SOURCE_DIR) / "tests" / "data" / "top";

// A whole force field seen as one term, so that the finite-difference checks see V(q) with the
// sites placed inside.
class FieldAsTerm : public ForceTerm {
 public:
  explicit FieldAsTerm(ForceField& field) : field_(field) {}
  std::vector<std::string> energy_names() const override { return {"potential"}; }
  void add_forces(const Coords& q, Coords& f, std::span<double> energies, const TermEvaluation&) override {
    Forces out;
    field_.compute(q, out);
    f += out.f;
    if (!energies.empty()) energies[0] += out.potential;
  }
  void add_hessian_vector(const Coords& q, const Coords& u, Coords& out, const TermEvaluation&) override {
    Coords hu;
    field_.hessian_vector(q, u, hu);
    out += hu;
  }
  void add_single_point(const Coords& q, Coords& f, std::span<double> energies) const override {
    Forces out;
    field_.single_point(q, out);
    f += out.f;
    if (!energies.empty()) energies[0] += out.potential;
  }

 private:
  ForceField& field_;
};

void exclude(System& s, int i, int j) {
  for (auto [a, b] : {std::pair{i, j}, std::pair{j, i}}) {
    auto& list = s.exclusions[a];
    if (std::find(list.begin(), list.end(), b) == list.end()) list.insert(std::upper_bound(list.begin(), list.end(), b), b);
  }
}

// Appends a charged, LJ-carrying site built by `site` (its `site` index is filled in), excluded
// from its molecule's atoms and sites.
void add_site(vt::TestSystem& t, VirtualSite site, double charge) {
  System& s = t.system;
  const int n = s.n_atoms(), molecule = s.molecule[site.i];
  site.site = n;
  s.mass.conservativeResize(n + 1);
  s.mass[n] = 0;
  s.charge.conservativeResize(n + 1);
  s.charge[n] = charge;
  s.atom_names.push_back("MW");
  s.residue_names.push_back("SOL");
  s.residue_numbers.push_back(molecule + 1);
  s.molecule.push_back(molecule);
  s.type.push_back(1);
  s.exclusions.emplace_back();
  for (int a = 0; a < n; ++a)
    if (s.molecule[a] == molecule) exclude(s, a, n);
  s.virtual_sites.push_back(site);
  t.q.conservativeResize(3, n + 1);
  t.q.col(n).setZero();  // the field places it
}

// Per water-like molecule (O, H1, H2 = atoms 3m, 3m+1, 3m+2): a site of each given kind from
// (O, H1, H2), with parameters that put it near the molecule as the force fields' do.
VirtualSite site_of(Kind kind, int o) {
  switch (kind) {
    case Kind::two: return {kind, -1, o, o + 1, -1, 0.3, 0, 0};
    case Kind::two_fd: return {kind, -1, o, o + 1, -1, 0.05, 0, 0};
    case Kind::three: return {kind, -1, o, o + 1, o + 2, 0.131937768, 0.131937768, 0};
    case Kind::three_fd: return {kind, -1, o, o + 1, o + 2, 0.4, 0.02, 0};
    case Kind::three_fad: {
      const double theta = 100 * M_PI / 180, d = 0.05;
      return {kind, -1, o, o + 1, o + 2, d * std::cos(theta), d * std::sin(theta), 0};
    }
    case Kind::three_out: return {kind, -1, o, o + 1, o + 2, -0.344908262, -0.34490826, -6.4437903493};
  }
  return {};
}

const std::vector<std::pair<Kind, const char*>> kKinds = {
    {Kind::two, "2"},          {Kind::two_fd, "2fd"},       {Kind::three, "3"},
    {Kind::three_fd, "3fd"},   {Kind::three_fad, "3fad"},   {Kind::three_out, "3out"},
};

constexpr int kMolecules = 5;

vt::TestSystem waters_with_sites(Kind kind, std::uint64_t seed) {
  auto t = vt::water_like_system(kMolecules, Vec3(2.0, 2.0, 2.0), seed);
  for (int m = 0; m < kMolecules; ++m) add_site(t, site_of(kind, 3 * m), m % 2 ? -0.4 : 0.3);
  return t;
}

void check_field(const vt::TestSystem& t, const std::string& what, double step = vt::kStep) {
  auto field = make_force_field(t.system, vt::pair_config("potential-switch", "reaction-field", 0));
  FieldAsTerm term(*field);
  expect_derivatives_match(term, t.q, what, step);
}

}  // namespace

TEST(VirtualSites, EveryConstructionMatchesFiniteDifferences) {
  for (const auto& [kind, name] : kKinds) check_field(waters_with_sites(kind, 3), std::string("vsite") + name);
}

// A site built from a site: its force reaches the atoms through both constructions, and the
// Hessian's curvature term uses the whole force on the inner site.
TEST(VirtualSites, SiteBuiltFromASite) {
  auto t = vt::water_like_system(kMolecules, Vec3(2.0, 2.0, 2.0), 4);
  for (int m = 0; m < kMolecules; ++m) {
    const int inner = t.system.n_atoms();
    add_site(t, site_of(Kind::three_fd, 3 * m), -0.5);
    VirtualSite outer = site_of(Kind::three_out, 3 * m);
    outer.i = inner;  // from the inner site and the two H
    outer.a = outer.b = -0.2;
    outer.c = 3.0;
    add_site(t, outer, 0.25);
  }
  check_field(t, "3out from a 3fd site");
}

// Where the construction's direction is nearly undefined (H–O–H at 179.5°: 3fd's t and 3fad's p
// are ~4e-4 and ~9e-4 nm long), the derivatives are large but still exact. The differences use a
// step well below those lengths.
TEST(VirtualSites, NearlyDegenerateGeometry) {
  for (Kind kind : {Kind::two_fd, Kind::three_fd, Kind::three_fad, Kind::three_out}) {
    auto t = waters_with_sites(kind, 5);
    for (int m = 0; m < kMolecules; ++m) {
      const int o = 3 * m;
      const Vec3 oh = t.q.col(o + 1) - t.q.col(o);
      const Vec3 axis = oh.unitOrthogonal();
      t.q.col(o + 2) = t.q.col(o) + Eigen::AngleAxisd(M_PI - 0.5 * M_PI / 180, axis) * oh;
      if (kind == Kind::two_fd) t.q.col(o + 1) = t.q.col(o) + 0.01 * oh.normalized();  // a short O–H
    }
    check_field(t, "near-degenerate " + std::to_string(static_cast<int>(kind)), 1e-6);
  }
}

// The sites' velocities are the derivative of their positions along the atoms' velocities.
TEST(VirtualSites, PlacedVelocitiesAreTheTimeDerivativeOfThePositions) {
  for (const auto& [kind, name] : kKinds) {
    SCOPED_TRACE(name);
    auto t = waters_with_sites(kind, 6);
    auto field = make_force_field(t.system, vt::pair_config("potential-switch", "reaction-field", 0));
    const Coords v = vt::random_direction(t.system.n_atoms(), 8);
    const double h = 1e-6;
    auto positions = [&](double s) {
      Coords q = t.q + s * v, unused;
      field->place_sites(q, unused);
      return q;
    };
    Coords q = t.q, placed_v = v;
    field->place_sites(q, placed_v);
    const Coords fd = (positions(h) - positions(-h)) / (2 * h);
    for (const VirtualSite& s : t.system.virtual_sites) {
      EXPECT_LT((placed_v.col(s.site) - fd.col(s.site)).norm(), 1e-7 * fd.col(s.site).norm());
      EXPECT_EQ(placed_v.col(s.i), v.col(s.i));  // the atoms' own are untouched
    }
  }
}

namespace {

// 8 rigid TIP4P/2005 waters from tests/data/top/tip4p2005.top in a cluster whose pairs all stay
// inside the 1.5 nm cut-off (smooth forces), at 300 K.
struct Tip4pCluster {
  System system;
  std::unique_ptr<ForceField> field;
  Constraints constraints;
  std::unique_ptr<Problem> problem;
  State start;

  Tip4pCluster() {
    system = read_topology(kTop / "tip4p2005.top");
    std::mt19937_64 rng(12);
    std::normal_distribution<double> normal;
    start.q = Coords::Zero(3, system.n_atoms());
    const double half_angle = 52.26 * M_PI / 180, d_oh = 0.09572;
    for (int m = 0; m < 8; ++m) {
      const Vec3 centre = 0.31 * Vec3(m % 2, (m / 2) % 2, m / 4);
      const Vec3 axis = Vec3(normal(rng), normal(rng), normal(rng)).normalized();
      const Vec3 perp = axis.unitOrthogonal();
      start.q.col(4 * m) = centre;
      start.q.col(4 * m + 1) = centre + d_oh * (std::cos(half_angle) * axis + std::sin(half_angle) * perp);
      start.q.col(4 * m + 2) = centre + d_oh * (std::cos(half_angle) * axis - std::sin(half_angle) * perp);
    }
    ForceFieldConfig ff = vt::pair_config("potential-shift", "reaction-field", 0, 1.5);
    field = make_force_field(system, ff);
    constraints = Constraints(system.constraints, system.n_atoms(), system.box);
    problem = std::make_unique<Problem>(Problem{system, *field, constraints, system.inverse_mass()});
    start.v = Coords::Zero(3, system.n_atoms());
    for (int i = 0; i < system.n_atoms(); ++i)
      if (system.mass[i] > 0)
        for (int k = 0; k < 3; ++k) start.v(k, i) = std::sqrt(kBoltzmann * 300 / system.mass[i]) * normal(rng);
    start.v.colwise() -= start.v * system.mass / system.mass.sum();
    constraints.project_velocities(start.q, start.v, problem->inverse_mass);
  }
};

struct Conservation {
  double energy_range = 0, mean_kinetic = 0, momentum_change = 0;
};

Conservation run(Tip4pCluster& c, Integrator& integrator, int steps) {
  State s = c.start;
  integrator.init(*c.problem, s);
  const Vec3 p0 = s.v * c.system.mass;
  double lo = INFINITY, hi = -INFINITY;
  Conservation out;
  for (int k = 0; k < steps; ++k) {
    integrator.step(*c.problem, s);
    ++s.step;
    const double kinetic = integrator.kinetic_energy(*c.problem, s);
    lo = std::min(lo, s.potential + kinetic);
    hi = std::max(hi, s.potential + kinetic);
    out.mean_kinetic += kinetic / steps;
    out.momentum_change = std::max(out.momentum_change, (s.v * c.system.mass - p0).norm());
  }
  out.energy_range = hi - lo;
  return out;
}

}  // namespace

TEST(VirtualSites, Tip4p2005TopologyAsGromppReadsIt) {
  const System s = read_topology(kTop / "tip4p2005.top");
  ASSERT_EQ(s.n_atoms(), 32);
  ASSERT_EQ(s.virtual_sites.size(), 8u);
  const VirtualSite& m = s.virtual_sites[1];
  EXPECT_EQ(m.kind, Kind::three);
  EXPECT_EQ(m.site, 7);
  EXPECT_EQ(m.i, 4);
  EXPECT_EQ(m.j, 5);
  EXPECT_EQ(m.k, 6);
  EXPECT_DOUBLE_EQ(m.a, 0.131937768);
  EXPECT_EQ(s.mass[7], 0.0);
  EXPECT_DOUBLE_EQ(s.charge[7], -1.1128);
  EXPECT_EQ(s.exclusions[7], (std::vector<int>{4, 5, 6}));
  // 3 per molecule: the site's coordinates are not degrees of freedom, SETTLE removes 3.
  EXPECT_EQ(s.degrees_of_freedom(), 8 * (9 - 3));
  // GROMACS's construction order (2-atom kinds first) whatever the file order; 3fad's angle and
  // distance become d cos θ, d sin θ.
  const System all = read_topology(kTop / "vsites_all_kinds.top");
  std::vector<Kind> kinds;
  for (const VirtualSite& v : all.virtual_sites) kinds.push_back(v.kind);
  EXPECT_EQ(kinds, (std::vector<Kind>{Kind::two, Kind::two_fd, Kind::three, Kind::three_fd, Kind::three_fad,
                                      Kind::three_out}));
  EXPECT_NEAR(all.virtual_sites[4].a, 0.05 * std::cos(110 * M_PI / 180), 1e-15);
  EXPECT_NEAR(all.virtual_sites[4].b, 0.05 * std::sin(110 * M_PI / 180), 1e-15);
  EXPECT_EQ(all.virtual_sites[5].c, -6.4437903493);
}

// A rigid TIP4P/2005 cluster (the M sites carry the negative charge) over 0.05 ps: the energy's
// range falls with the step as the integrator's order says (RATTLE 2, vi rk4 4: measured ratios
// 3.9 and 15 from 1 to 0.5 fs, 1.8e-3 and 7e-6 of the kinetic energy at 1 fs over 0.1 ps), which
// it would not if the sites' forces reached their atoms wrongly; linear momentum (no box) is kept
// but for round-off and the solver's tolerance. Anderson mixing divides by the inverse mass,
// which is 0 on the sites.
TEST(VirtualSites, RigidTip4p2005ConservesEnergyAndMomentumAtTheIntegratorsOrder) {
  Tip4pCluster c;
  struct Case {
    const char* type;
    const char* acceleration;
    double min_ratio, max_ratio;  // of the energy ranges at 1 and 0.5 fs
  };
  for (const Case& k : {Case{"rattle", "none", 3, 5}, Case{"vi", "none", 10, 25}, Case{"vi", "anderson", 10, 25}}) {
    SCOPED_TRACE(std::string(k.type) + " " + k.acceleration);
    std::vector<Conservation> results;
    for (double dt : {0.001, 0.0005}) {
      IntegratorConfig config;
      config.type = k.type;
      config.dt = dt;
      config.acceleration = k.acceleration;
      config.solver_tolerance = 1e-12;
      auto integrator = make_integrator(config);
      results.push_back(run(c, *integrator, static_cast<int>(std::lround(0.05 / dt))));
      EXPECT_GT(results.back().mean_kinetic, 0.0);
      EXPECT_LT(results.back().momentum_change, 1e-9);
    }
    const double ratio = results[0].energy_range / results[1].energy_range;
    std::printf("  %s %s: energy range %.2e of the kinetic energy at 1 fs, ratio %.1f to 0.5 fs\n", k.type,
                k.acceleration, results[0].energy_range / results[0].mean_kinetic, ratio);
    EXPECT_GT(ratio, k.min_ratio);
    EXPECT_LT(ratio, k.max_ratio);
  }
}

// The run loop leaves the sites placed and moving with their atoms in every state it hands out.
TEST(VirtualSites, TheRunLoopPlacesTheSites) {
  Tip4pCluster c;
  IntegratorConfig config;
  config.type = "rattle";
  config.dt = 0.001;
  auto integrator = make_integrator(config);
  Simulation simulation(*c.problem, *integrator, config.dt);
  State s = c.start;
  simulation.run(s, 3);
  Coords q = s.q, v = s.v;
  c.field->place_sites(q, v);
  EXPECT_EQ(q, s.q);
  EXPECT_EQ(v, s.v);
  for (const VirtualSite& m : c.system.virtual_sites) {
    EXPECT_GT(s.v.col(m.site).norm(), 0.0);
    EXPECT_EQ(s.f.col(m.site).norm(), 0.0);
  }
}

// A checkpoint is refused for a system whose sites are built differently.
TEST(VirtualSites, CheckpointIdentityCoversTheSites) {
  System s = read_topology(kTop / "tip4p2005.top");
  const RunConfig config;
  const RunIdentity before = run_identity(s, config, run_schema(), 1);
  s.virtual_sites[3].b += 1e-9;
  EXPECT_NE(run_identity(s, config, run_schema(), 1), before);
}

