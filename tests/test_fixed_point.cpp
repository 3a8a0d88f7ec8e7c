// The variational integrator's generic solver parts on their own: the iteration control
// (convergence, damping, settling on a jump, predicted stops) and Anderson mixing, on toy maps.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "integrators/anderson.hpp"
#include "integrators/fixed_point.hpp"

namespace vimd {
namespace {

using Verdict = FixedPointControl::Verdict;

TEST(FixedPointControl, ConvergesAtTheToleranceOnlyWhereAllowed) {
  FixedPointControl control(50, /*predicted_stop=*/false);
  control.begin(1e-8);
  EXPECT_EQ(control.judge(1e-9, /*may_end=*/false), Verdict::update);
  EXPECT_EQ(control.judge(1e-9), Verdict::converged);
  EXPECT_EQ(control.iterations(), 2);
  control.begin(1e-8);
  EXPECT_EQ(control.judge(std::numeric_limits<double>::quiet_NaN()), Verdict::not_finite);
  control.begin(1e-8);
  EXPECT_EQ(control.judge(std::numeric_limits<double>::infinity()), Verdict::not_finite);
}

TEST(FixedPointControl, PredictsTheStopFromTheContraction) {
  FixedPointControl control(50, /*predicted_stop=*/true);
  // The first solve knows no contraction factor (1): it stops only on a residual within the tolerance.
  control.begin(1e-8);
  EXPECT_EQ(control.judge(1e-6), Verdict::update);
  EXPECT_EQ(control.judge(1e-7), Verdict::update);
  EXPECT_EQ(control.judge(1e-9), Verdict::converged);
  EXPECT_NEAR(control.contraction(), 0.1, 1e-12);  // the largest factor of the solve
  // The next one never stops on its first residual; on its second, the update is predicted to
  // land at max(0.4, 0.1)·2e-8 = 8e-9, within the tolerance.
  control.begin(1e-8);
  EXPECT_EQ(control.judge(5e-8), Verdict::update);
  EXPECT_EQ(control.judge(2e-8), Verdict::converged_by_update);
  EXPECT_NEAR(control.predicted_residual(), 8e-9, 1e-20);
  EXPECT_NEAR(control.contraction(), 0.4, 1e-12);
  // The estimate is the larger of this solve's factor (0.3) and the last one's (0.4): 1.2e-8 is not
  // within the tolerance, though 0.3·3e-8 would be.
  control.begin(1e-8);
  EXPECT_EQ(control.judge(1e-7), Verdict::update);
  EXPECT_EQ(control.judge(3e-8), Verdict::update);
  // Without predicted stops the same residuals iterate on.
  FixedPointControl plain(50, /*predicted_stop=*/false);
  plain.set_contraction(0.1);
  plain.begin(1e-8);
  EXPECT_EQ(plain.judge(5e-8), Verdict::update);
  EXPECT_EQ(plain.judge(2e-8), Verdict::update);
}

TEST(FixedPointControl, DampsACycleAndSettlesOnAJump) {
  // A residual that cycles across a jump, never below 3e-8 (tolerance 1e-8): the control halves
  // the relaxation until the steps, relaxation × residual, are within the tolerance.
  FixedPointControl control(60, /*predicted_stop=*/true);
  control.begin(1e-8);
  Verdict verdict = Verdict::update;
  int k = 0;
  double smallest_relaxation = 1;
  while (verdict == Verdict::update) {
    verdict = control.judge(k++ % 2 ? 3e-8 : 5e-7);
    smallest_relaxation = std::min(smallest_relaxation, control.relaxation());
  }
  EXPECT_EQ(verdict, Verdict::settled_at_jump);
  EXPECT_LT(smallest_relaxation, 1);
  EXPECT_LT(control.iterations(), 60);
  // A cycle far above the tolerance is no jump: the iteration gives up at max_iterations.
  control.begin(1e-8);
  k = 0;
  do verdict = control.judge(k++ % 2 ? 1e-3 : 2e-3);
  while (verdict == Verdict::update);
  EXPECT_EQ(verdict, Verdict::exhausted);
  EXPECT_EQ(control.iterations(), 60);
}

// x ← T(x) = A x + b with a non-normal A of spectral radius 0.9, on 64 blocks of 2 entries.
struct LinearMap {
  static constexpr int kBlocks = 64;
  using Vector = AndersonMixer<2>::Vector;
  Eigen::Matrix2d a;
  Vector b = Vector::Zero(2, kBlocks);
  LinearMap() {
    a << 0.9, 0.5, 0.0, -0.8;
    for (int i = 0; i < kBlocks; ++i) b.col(i) << std::sin(i), std::cos(3.0 * i);
  }
  Vector apply(const Vector& x) const { return a * x + b; }
  Vector solution() const { return (Eigen::Matrix2d::Identity() - a).inverse() * b; }
};

int iterations_to_converge(int depth, double tolerance) {
  const LinearMap map;
  LinearMap::Vector x = LinearMap::Vector::Zero(2, LinearMap::kBlocks);
  AndersonMixer<2> mixer(std::max(depth, 1), LinearMap::kBlocks);
  for (int k = 1; k <= 1000; ++k) {
    const LinearMap::Vector tx = map.apply(x);
    if ((tx - x).cwiseAbs().maxCoeff() <= tolerance) {
      EXPECT_LT((x - map.solution()).cwiseAbs().maxCoeff(), 100 * tolerance) << "depth " << depth;
      return k;
    }
    if (depth == 0) {
      x = tx;
      continue;
    }
    mixer.record([&](int i, auto xi, auto fi) {
      xi = x.col(i);
      fi = tx.col(i) - x.col(i);
    });
    mixer.mix([&](int i, const Eigen::Vector2d& mixed) { x.col(i) = mixed; });
  }
  return 1000;
}

TEST(AndersonMixer, SolvesALinearMapInFewIterations) {
  const int plain = iterations_to_converge(0, 1e-12);
  const int mixed = iterations_to_converge(4, 1e-12);
  EXPECT_GT(plain, 100);  // 0.9^k
  // On a 2-dimensional map (per block, the blocks alike) two differences span the space: Anderson
  // is then exact up to round-off after a few iterations.
  EXPECT_LT(mixed, 10);
}

TEST(AndersonMixer, FirstMixIsThePlainUpdateAndRestartForgets) {
  AndersonMixer<1> mixer(3, 2);
  auto record = [&](double x, double f) {
    mixer.record([&](int, auto xi, auto fi) {
      xi(0) = x;
      fi(0) = f;
    });
  };
  double out = 0;
  auto take = [&](int, const Eigen::Matrix<double, 1, 1>& x) { out = x(0); };
  record(1.0, 0.5);
  mixer.mix(take);
  EXPECT_EQ(out, 1.5);
  // T(x) = 0.5 x + 1 (fixed point 2): from x = 1.5, f = 0.25; the secant through the two iterates
  // lands on the fixed point (up to the regularisation).
  record(1.5, 0.25);
  mixer.mix(take);
  EXPECT_NEAR(out, 2.0, 1e-9);
  mixer.restart();
  record(1.5, 0.25);
  mixer.mix(take);
  EXPECT_EQ(out, 1.75);
}

}  // namespace
}  // namespace vimd
