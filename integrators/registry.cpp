#include "integrators/registry.hpp"

#include "engine/errors.hpp"

namespace vimd {

// Placeholder until the integrators land (owner: integrators helper).
std::unique_ptr<Integrator> make_integrator(const IntegratorConfig& config) {
  throw InputError("", 0, "unknown integrator type '" + config.type + "'");
}

std::vector<std::string> integrator_names() { return {}; }

}  // namespace vimd
