#include "engine/integrator.hpp"

namespace vimd {

double kinetic_energy(const Eigen::VectorXd& mass, const Coords& v) {
  return 0.5 * (v.colwise().squaredNorm().transpose().array() * mass.array()).sum();
}

double Integrator::kinetic_energy(const Problem& problem, const State& state) const {
  return vimd::kinetic_energy(problem.system.mass, state.v);
}

}  // namespace vimd
