// The standard layer against the dense reference: the test LJ term's forces and HVP, the
// constrained acceleration A and its VJP, a whole explicit RK step (forward and discrete adjoint)
// for every built-in tableau and both signs of τ, and the projection P with its pull-back.
// Derivatives of the dense code come from dual numbers, so they are exact to round-off.
#include <gtest/gtest.h>

#include <random>

#include "dense_reference.hpp"
#include "integrators/constrained_dynamics.hpp"
#include "integrators/explicit_rk.hpp"
#include "integrators/projection.hpp"

namespace vimd {
namespace {

using dense::Dual;
using dense::Vec;

struct Fixture {
  Vec<double> q0, v0;
  dense::DenseSystem system;
  std::unique_ptr<dense::EngineProblem> engine;
};

Fixture make(const std::string& which) {
  Fixture f;
  if (which == "two_dimers")
    f.system = dense::two_dimers(f.q0, f.v0);
  else if (which == "two_chains")
    f.system = dense::two_chains(f.q0, f.v0);
  else
    f.system = dense::triangle_and_atom(f.q0, f.v0);
  f.engine = std::make_unique<dense::EngineProblem>(f.system);
  return f;
}

Vec<double> random_vec(std::mt19937& rng, int n, double scale) {
  std::normal_distribution<double> normal(0.0, scale);
  Vec<double> x(n);
  for (auto& e : x) e = normal(rng);
  return x;
}

Vec<double> add(const Vec<double>& a, const Vec<double>& b) {
  Vec<double> c = a;
  for (std::size_t i = 0; i < c.size(); ++i) c[i] += b[i];
  return c;
}

double max_abs_diff(const Vec<double>& a, const Vec<double>& b) {
  double m = 0;
  for (std::size_t i = 0; i < a.size(); ++i) m = std::max(m, std::abs(a[i] - b[i]));
  return m;
}

double max_abs(const Vec<double>& a) { return max_abs_diff(a, Vec<double>(a.size(), 0.0)); }

// ā·J for a vector function F of x ∈ R^n, J by forward-mode duals column by column.
template <class F>
Vec<double> dual_vjp(F&& function, const Vec<double>& x, const Vec<double>& a_bar) {
  Vec<double> out(x.size());
  for (std::size_t j = 0; j < x.size(); ++j) {
    Vec<Dual<double>> xd(x.begin(), x.end());
    xd[j].b = 1.0;
    Vec<Dual<double>> y = function(xd);
    double s = 0;
    for (std::size_t i = 0; i < y.size(); ++i) s += a_bar[i] * y[i].b;
    out[j] = s;
  }
  return out;
}

TEST(TestPotential, ForcesAndHessianVectorMatchDualNumbers) {
  Fixture f = make("triangle_and_atom");
  std::mt19937 rng(5);
  Vec<double> q = add(f.q0, random_vec(rng, 12, 0.01)), u = random_vec(rng, 12, 1.0);
  Forces forces;
  f.engine->force_field.compute(dense::to_coords(q), forces);
  Vec<double> grad = f.system.gradient(q);
  for (int i = 0; i < 12; ++i) EXPECT_NEAR(-forces.f.data()[i], grad[i], 1e-12 * max_abs(grad));
  // Gradient from the energy by duals, HVP as the directional derivative of the gradient.
  for (int j = 0; j < 12; ++j) {
    Vec<Dual<double>> qd(q.begin(), q.end());
    qd[j].b = 1.0;
    EXPECT_NEAR(f.system.potential(qd).b, grad[j], 1e-12 * max_abs(grad));
  }
  Vec<Dual<double>> qd(q.size());
  for (int i = 0; i < 12; ++i) qd[i] = Dual<double>(q[i], u[i]);
  Vec<Dual<double>> g = f.system.gradient(qd);
  Coords hu;
  f.engine->force_field.hessian_vector(dense::to_coords(q), dense::to_coords(u), hu);
  for (int i = 0; i < 12; ++i) EXPECT_NEAR(hu.data()[i], g[i].b, 1e-12 * std::max(1.0, std::abs(g[i].b)));
}

class AccelerationTest : public ::testing::TestWithParam<std::string> {};

TEST_P(AccelerationTest, ValueAndVjpMatchDualNumbers) {
  Fixture f = make(GetParam());
  std::mt19937 rng(11);
  const int N = f.system.dim();
  // Slightly off the manifold, as RK stages are.
  Vec<double> q = add(f.q0, random_vec(rng, N, 0.01)), v = add(f.v0, random_vec(rng, N, 0.01));
  Vec<double> a_bar = random_vec(rng, N, 1.0);

  ConstrainedDynamics dyn(f.engine->problem);
  DynamicsPoint point;
  dyn.evaluate(dense::to_coords(q), dense::to_coords(v), point);
  Vec<double> a_ref = dense::acceleration(f.system, q, v);
  EXPECT_LT(max_abs_diff(dense::to_vec(point.a), a_ref), 1e-12 * max_abs(a_ref));
  EXPECT_NEAR(point.lagrangian, dense::lagrangian(f.system, q, v), 1e-12);

  Coords q_bar = Coords::Zero(3, N / 3), v_bar = Coords::Zero(3, N / 3);
  dyn.add_vjp(point, dense::to_coords(a_bar), q_bar, v_bar);
  auto of_q = [&](const Vec<Dual<double>>& x) { return dense::acceleration(f.system, x, dense::promote<Dual<double>>(v)); };
  auto of_v = [&](const Vec<Dual<double>>& x) { return dense::acceleration(f.system, dense::promote<Dual<double>>(q), x); };
  Vec<double> ref_q = dual_vjp(of_q, q, a_bar), ref_v = dual_vjp(of_v, v, a_bar);
  EXPECT_LT(max_abs_diff(dense::to_vec(q_bar), ref_q), 1e-11 * max_abs(ref_q)) << "ā·∂A/∂q";
  EXPECT_LT(max_abs_diff(dense::to_vec(v_bar), ref_v), 1e-11 * max_abs(ref_v)) << "ā·∂A/∂v";
}

INSTANTIATE_TEST_SUITE_P(Systems, AccelerationTest, ::testing::Values("two_dimers", "triangle_and_atom"));

class RungeKuttaTest : public ::testing::TestWithParam<std::tuple<std::string, double>> {};

TEST_P(RungeKuttaTest, ForwardAndDiscreteAdjointMatchDualNumbers) {
  const auto& [name, tau] = GetParam();
  Fixture f = make("triangle_and_atom");
  const ButcherTableau& tab = builtin_tableau(name);
  const int N = f.system.dim();
  std::mt19937 rng(3);
  Vec<double> q = f.q0, v = f.v0;
  Vec<double> q_seed = random_vec(rng, N, 1.0), v_seed = random_vec(rng, N, 1.0);
  const double s_seed = 0.7;

  ExplicitRungeKutta rk(tab);
  ConstrainedDynamics dyn(f.engine->problem);
  Segment seg;
  rk.forward(dyn, dense::to_coords(q), dense::to_coords(v), tau, seg);
  dense::FlowResult<double> ref = dense::rk_flow(f.system, tab, tau, q, v);
  EXPECT_LT(max_abs_diff(dense::to_vec(seg.q), ref.q), 1e-13);
  EXPECT_LT(max_abs_diff(dense::to_vec(seg.v), ref.v), 1e-12 * max_abs(ref.v));
  EXPECT_NEAR(seg.action, ref.action, 1e-13);

  // ȳ₁·DΦ with ȳ₁ = (Q̄, V̄, S̄), against the dual-number Jacobian of the dense flow.
  auto flow_seeded = [&](const Vec<Dual<double>>& qv) {
    Vec<Dual<double>> qq(qv.begin(), qv.begin() + N), vv(qv.begin() + N, qv.end());
    dense::FlowResult<Dual<double>> r = dense::rk_flow(f.system, tab, tau, qq, vv);
    Vec<Dual<double>> out = r.q;
    out.insert(out.end(), r.v.begin(), r.v.end());
    out.push_back(r.action);
    return out;
  };
  Vec<double> qv = q;
  qv.insert(qv.end(), v.begin(), v.end());
  Vec<double> seed = q_seed;
  seed.insert(seed.end(), v_seed.begin(), v_seed.end());
  seed.push_back(s_seed);
  Vec<double> expected = dual_vjp(flow_seeded, qv, seed);

  Coords q_bar, v_bar;
  Coords v_seed_c = dense::to_coords(v_seed);
  rk.vjp(dyn, seg, dense::to_coords(q_seed), &v_seed_c, s_seed, q_bar, v_bar);
  Vec<double> got = dense::to_vec(q_bar);
  for (double x : dense::to_vec(v_bar)) got.push_back(x);
  EXPECT_LT(max_abs_diff(got, expected), 1e-11 * max_abs(expected));

  // With V̄ = 0 (as the variational integrator seeds it) the skipped last-stage HVP changes nothing.
  seed.assign(seed.size(), 0.0);
  for (int i = 0; i < N; ++i) seed[i] = q_seed[i];
  seed.back() = s_seed;
  expected = dual_vjp(flow_seeded, qv, seed);
  const long hvps = f.engine->force_field.work().hessian_evaluations;
  rk.vjp(dyn, seg, dense::to_coords(q_seed), nullptr, s_seed, q_bar, v_bar);
  EXPECT_LE(f.engine->force_field.work().hessian_evaluations - hvps, tab.stages());
  got = dense::to_vec(q_bar);
  for (double x : dense::to_vec(v_bar)) got.push_back(x);
  EXPECT_LT(max_abs_diff(got, expected), 1e-11 * max_abs(expected));

  // Deferring the start point's Hessian–vector product to the caller gives the same result.
  Coords direction = Coords::Zero(3, N / 3), hv;
  rk.vjp(dyn, seg, dense::to_coords(q_seed), nullptr, s_seed, q_bar, v_bar, &direction);
  f.engine->force_field.hessian_vector(dense::to_coords(q), direction, hv);
  q_bar -= hv;
  Vec<double> deferred = dense::to_vec(q_bar);
  for (double x : dense::to_vec(v_bar)) deferred.push_back(x);
  EXPECT_LT(max_abs_diff(deferred, got), 1e-13 * max_abs(expected));
}

INSTANTIATE_TEST_SUITE_P(Tableaus, RungeKuttaTest,
                         ::testing::Combine(::testing::Values("euler", "heun2", "midpoint", "rk3", "rk4", "rk38", "rk6", "rk8"),
                                            ::testing::Values(0.05, -0.03)),
                         [](const auto& info) {
                           return std::get<0>(info.param) + (std::get<1>(info.param) > 0 ? "_forward" : "_backward");
                         });

class ProjectionTest : public ::testing::TestWithParam<std::tuple<std::string, std::string>> {};

TEST_P(ProjectionTest, ValueAndPullBackMatchDualNumbers) {
  const auto& [system, kind] = GetParam();
  Fixture f = make(system);
  const int N = f.system.dim();
  std::mt19937 rng(7);
  Vec<double> y = add(f.q0, random_vec(rng, N, 1e-3)), p = random_vec(rng, N, 1.0);
  Vec<double> inverse_weight;
  for (double m : f.system.mass) inverse_weight.push_back(kind == "mass" ? 1 / m : 1.0);

  Projection projection(f.engine->constraints, f.engine->problem.inverse_mass, kind);
  ProjectedPoint point;
  projection.project(dense::to_coords(y), point, 0);
  Vec<double> x_ref = dense::project(f.system, y, inverse_weight);
  EXPECT_LT(max_abs_diff(dense::to_vec(point.x), x_ref), 1e-14);
  EXPECT_LT(f.engine->constraints.max_relative_deviation(point.x), 1e-14);

  Coords p_hat;
  projection.pull_back(point, dense::to_coords(p), p_hat, 0);
  auto of_y = [&](const Vec<Dual<double>>& yd) { return dense::project(f.system, yd, inverse_weight); };
  Vec<double> expected = dual_vjp(of_y, y, p);
  EXPECT_LT(max_abs_diff(dense::to_vec(p_hat), expected), 1e-12 * max_abs(expected));
}

INSTANTIATE_TEST_SUITE_P(Kinds, ProjectionTest,
                         ::testing::Combine(::testing::Values("two_dimers", "triangle_and_atom", "two_chains"),
                                            ::testing::Values("euclidean", "mass")),
                         [](const auto& info) { return std::get<0>(info.param) + "_" + std::get<1>(info.param); });

TEST(TangentProjector, ProjectsOntoTheKernelOfG) {
  Fixture f = make("triangle_and_atom");
  std::mt19937 rng(9);
  Coords q = dense::to_coords(f.q0), u = dense::to_coords(random_vec(rng, 12, 1.0));
  TangentProjector projector(f.engine->constraints, f.engine->problem.inverse_mass);
  projector.set_point(q);
  Coords projected = u;
  projector.apply(projected);
  Eigen::VectorXd gu;
  f.engine->constraints.apply_G(q, projected, gu);
  EXPECT_LT(gu.cwiseAbs().maxCoeff(), 1e-14);
  // Idempotent, and the removed part is M⁻¹Gᵀμ (M-orthogonal to the kernel).
  Coords twice = projected;
  projector.apply(twice);
  EXPECT_LT((twice - projected).cwiseAbs().maxCoeff(), 1e-14);
}

}  // namespace
}  // namespace vimd
