#include "integrators/registry.hpp"

#include "engine/errors.hpp"
#include "integrators/minimize.hpp"
#include "integrators/projected_rk.hpp"
#include "integrators/rattle.hpp"
#include "integrators/shake.hpp"
#include "integrators/variational.hpp"
#include "integrators/verlet.hpp"

namespace vimd {

namespace {

template <class T>
std::unique_ptr<Integrator> build(const IntegratorConfig& config) {
  return std::make_unique<T>(config);
}

struct Entry {
  const char* name;
  std::unique_ptr<Integrator> (*make)(const IntegratorConfig&);
};

// One line per integrator; make_integrator and integrator_names both read this table.
constexpr Entry kIntegrators[] = {
    {"verlet", build<VelocityVerlet>},
    {"shake", build<Shake>},
    {"rattle", build<Rattle>},
    {"vi", build<VariationalIntegrator>},
    {"rk", build<ProjectedRungeKutta>},
    {"minimize", build<SteepestDescent>},
};

}  // namespace

std::unique_ptr<Integrator> make_integrator(const IntegratorConfig& config) {
  for (const Entry& e : kIntegrators)
    if (config.type == e.name) return e.make(config);
  std::string valid;
  for (const Entry& e : kIntegrators) valid += std::string(valid.empty() ? "" : ", ") + "\"" + e.name + "\"";
  throw SettingError("integrator", "type", "unknown type \"" + config.type + "\"; valid types: " + valid);
}

std::vector<std::string> integrator_names() {
  std::vector<std::string> names;
  for (const Entry& e : kIntegrators) names.emplace_back(e.name);
  return names;
}

}  // namespace vimd
