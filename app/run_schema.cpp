#include "app/run_schema.hpp"

#include "forcefields/settings.hpp"
#include "integrators/settings.hpp"

namespace vimd {

namespace {

void append(std::vector<ConfigKey>& keys, std::vector<ConfigKey> more) {
  keys.insert(keys.end(), std::make_move_iterator(more.begin()), std::make_move_iterator(more.end()));
}

ConfigSchema assemble() {
  ConfigSchema schema;
  // The reference's order: [system], [forcefield], [integrator] (type first, then the keys every
  // integrator shares, then the integrators' own), [output].
  append(schema.keys, system_keys());
  append(schema.keys, forcefield_keys());
  schema.keys.push_back(integrator_type_key());
  append(schema.keys, dynamics_keys());
  append(schema.keys, integrator_keys());
  append(schema.keys, output_keys());
  schema.rules = forcefield_rules();
  for (ConfigRule& rule : integrator_rules()) schema.rules.push_back(std::move(rule));
  return schema;
}

}  // namespace

const ConfigSchema& run_schema() {
  static const ConfigSchema schema = assemble();
  return schema;
}

}  // namespace vimd
