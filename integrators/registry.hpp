#pragma once
// The integrator registry: a plain function from the config's [integrator] table to an integrator.
#include <memory>
#include <string>
#include <vector>

#include "integrators/settings.hpp"
#include "engine/integrator.hpp"

namespace vimd {

std::unique_ptr<Integrator> make_integrator(const IntegratorConfig& config);
// All names make_integrator accepts (tests iterate this).
std::vector<std::string> integrator_names();

}  // namespace vimd
