#include "integrators/explicit_rk.hpp"

#include "integrators/coords_ops.hpp"

namespace vimd {

ExplicitRungeKutta::ExplicitRungeKutta(ButcherTableau tableau) : tableau_(std::move(tableau)) {
  stage_q_bar_.resize(tableau_.stages());
  stage_v_bar_.resize(tableau_.stages());
}

void ExplicitRungeKutta::forward(ConstrainedDynamics& dynamics, const Coords& q, const Coords& v, double tau,
                                 Segment& seg, const Forces* forces_at_q, const DynamicsPrecision& precision) {
  const int s = stages();
  const int n = static_cast<int>(q.cols());
  const Eigen::MatrixXd& a = tableau_.a;
  const Eigen::VectorXd& b = tableau_.b;
  seg.tau = tau;
  seg.stages.resize(s);
  stage_q_.resize(3, n);
  stage_v_.resize(3, n);
  for (int k = 0; k < s; ++k) {
    if (k == 0) {
      dynamics.evaluate(q, v, seg.stages[0], forces_at_q, /*segment_start=*/true, precision);
      continue;
    }
    // Y_k = y₀ + τ Σ_{j<k} a_kj K_j, with K_j = (v_j, A_j, L_j).
#pragma omp parallel for schedule(static) if (n >= kParallelMinAtoms)
    for (int i = 0; i < n; ++i) {
      Vec3 dq = Vec3::Zero(), dv = Vec3::Zero();
      for (int j = 0; j < k; ++j) {
        if (a(k, j) == 0) continue;
        dq += a(k, j) * seg.stages[j].v.col(i);
        dv += a(k, j) * seg.stages[j].a.col(i);
      }
      stage_q_.col(i) = q.col(i) + tau * dq;
      stage_v_.col(i) = v.col(i) + tau * dv;
    }
    dynamics.evaluate(stage_q_, stage_v_, seg.stages[k], nullptr, /*segment_start=*/false, precision);
  }
  seg.q.resize(3, n);
  seg.v.resize(3, n);
#pragma omp parallel for schedule(static) if (n >= kParallelMinAtoms)
  for (int i = 0; i < n; ++i) {
    Vec3 dq = Vec3::Zero(), dv = Vec3::Zero();
    for (int k = 0; k < s; ++k) {
      if (b[k] == 0) continue;
      dq += b[k] * seg.stages[k].v.col(i);
      dv += b[k] * seg.stages[k].a.col(i);
    }
    seg.q.col(i) = q.col(i) + tau * dq;
    seg.v.col(i) = v.col(i) + tau * dv;
  }
  seg.action = 0;
  for (int k = 0; k < s; ++k) seg.action += tau * b[k] * seg.stages[k].lagrangian;
}

void ExplicitRungeKutta::vjp(ConstrainedDynamics& dynamics, const Segment& seg, const Coords& q_seed,
                             const Coords* v_seed, double s_seed, Coords& q_bar, Coords& v_bar,
                             Coords* start_hvp, const DynamicsPrecision& precision) {
  const int s = stages();
  const int n = static_cast<int>(q_seed.cols());
  const double tau = seg.tau;
  const Eigen::MatrixXd& a = tableau_.a;
  const Eigen::VectorXd& b = tableau_.b;
  const Eigen::VectorXd& mass = dynamics.mass();
  k_q_bar_.resize(3, n);
  k_v_bar_.resize(3, n);
  q_bar.resize(3, n);
  v_bar.resize(3, n);
  for_each_atom(n, [&](int i) {
    q_bar.col(i) = q_seed.col(i);
    v_bar.col(i) = v_seed ? Vec3(v_seed->col(i)) : Vec3::Zero();
  });

  for (int k = s - 1; k >= 0; --k) {
    const DynamicsPoint& stage = seg.stages[k];
    // k̄_v is zero when neither the seed nor a later stage reaches it.
    bool v_reached = v_seed != nullptr && b[k] != 0;
    for (int j = k + 1; j < s; ++j) v_reached = v_reached || a(j, k) != 0;
    const double ks = tau * b[k] * s_seed;
    Coords& yq = stage_q_bar_[k];
    Coords& yv = stage_v_bar_[k];
    yq.resize(3, n);
    yv.resize(3, n);
#pragma omp parallel for schedule(static) if (n >= kParallelMinAtoms)
    for (int i = 0; i < n; ++i) {
      Vec3 kq = b[k] * q_seed.col(i);
      Vec3 kv = v_seed ? Vec3(b[k] * v_seed->col(i)) : Vec3::Zero();
      for (int j = k + 1; j < s; ++j) {
        if (a(j, k) == 0) continue;
        kq += a(j, k) * stage_q_bar_[j].col(i);
        kv += a(j, k) * stage_v_bar_[j].col(i);
      }
      k_q_bar_.col(i) = tau * kq;
      k_v_bar_.col(i) = tau * kv;
      yq.col(i) = ks * stage.forces.f.col(i);
      yv.col(i) = tau * kq + ks * mass[i] * stage.v.col(i);
    }
    // Stage 0 sits at the segment's start (a_0j = 0): its product may be deferred.
    if (v_reached) dynamics.add_vjp(stage, k_v_bar_, yq, yv, k == 0 ? start_hvp : nullptr, precision);
#pragma omp parallel for schedule(static) if (n >= kParallelMinAtoms)
    for (int i = 0; i < n; ++i) {
      q_bar.col(i) += yq.col(i);
      v_bar.col(i) += yv.col(i);
    }
  }
}

std::unique_ptr<OneStepMethod> make_one_step_method(const ButcherTableau& tableau) {
  return std::make_unique<ExplicitRungeKutta>(tableau);
}

}  // namespace vimd
