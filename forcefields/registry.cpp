#include "forcefields/registry.hpp"

#include "engine/errors.hpp"

namespace vimd {

// Placeholder until the force-field terms land (owner: forcefields helper).
std::unique_ptr<ForceField> make_force_field(const System&, const ForceFieldConfig&) {
  throw InputError("", 0, "force field not implemented yet");
}

}  // namespace vimd
