#include "integrators/projected_rk.hpp"

#include "engine/errors.hpp"
#include "integrators/constrained_dynamics.hpp"
#include "integrators/explicit_rk.hpp"
#include "integrators/projection.hpp"
#include "integrators/thermostat.hpp"
#include "integrators/verlet.hpp"

namespace vimd {

struct ProjectedRungeKutta::Work {
  Problem* problem;
  ConstrainedDynamics dynamics;
  ExplicitRungeKutta rk;
  Projection projection;
  TangentProjector mass_q;
  Segment segment;
  ProjectedPoint projected;
  Forces forces;  // at the current positions

  Work(Problem& p, const ButcherTableau& tableau, const std::string& kind)
      : problem(&p), dynamics(p), rk(tableau), projection(p.constraints, p.inverse_mass, kind),
        mass_q(p.constraints, p.inverse_mass) {}

  // Positions onto Q, velocities onto the tangent space there, forces at the new positions.
  void project_and_evaluate(const Coords& q, const Coords& v, State& state, long step) {
    projection.project(q, projected, step);
    state.q = projected.x;
    state.v = v;
    mass_q.set_point(state.q);
    mass_q.apply(state.v);
    problem->force_field.compute(state.q, forces);
    state.f = forces.f;
    state.potential = forces.potential;
    state.energy_terms = forces.terms;
  }
};

ProjectedRungeKutta::ProjectedRungeKutta(ButcherTableau tableau, double dt, std::string projection)
    : tableau_(std::move(tableau)), dt_(dt), projection_(std::move(projection)) {
  check_projection_kind(projection_);
}

ProjectedRungeKutta::ProjectedRungeKutta(const IntegratorConfig& config)
    : ProjectedRungeKutta(resolve_tableau(config.method, config), config.dt, config.projection) {
  check_step_config(config);
  refuse_thermostat(config,
                    "the Runge-Kutta integrators run NVE (the baseline for the variational ones); equilibrate "
                    "with type = \"rattle\" and thermostat = \"v-rescale\", then continue from its confout.gro");
}

ProjectedRungeKutta::~ProjectedRungeKutta() = default;

void ProjectedRungeKutta::init(Problem& problem, State& state) {
  check_start(problem, state);
  work_ = std::make_unique<Work>(problem, tableau_, projection_);
  // The start is on TQ already (the engine constrains it): only the forces there are needed.
  Work& work = *work_;
  problem.force_field.compute(state.q, work.forces);
  state.f = work.forces.f;
  state.potential = work.forces.potential;
  state.energy_terms = work.forces.terms;
}

void ProjectedRungeKutta::restore(Problem& problem, const State& state, const Carried&) {
  if (!work_ || work_->problem != &problem)
    throw std::logic_error("ProjectedRungeKutta::restore before init() for this problem");
  work_->forces.f = state.f;
  work_->forces.potential = state.potential;
  work_->forces.terms = state.energy_terms;
}

StepReport ProjectedRungeKutta::step(Problem& problem, State& state) {
  if (!work_ || work_->problem != &problem)
    throw std::logic_error("ProjectedRungeKutta::step before init() for this problem");
  Work& work = *work_;
  work.rk.forward(work.dynamics, state.q, state.v, dt_, work.segment, &work.forces);
  work.project_and_evaluate(work.segment.q, work.segment.v, state, state.step + 1);
  StepReport report;
  report.iterations = work.projected.iterations;
  report.residual = problem.constraints.max_relative_deviation(state.q);
  return report;
}

}  // namespace vimd
