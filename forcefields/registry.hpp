#pragma once
// The force-field registry: builds the terms a system needs from its topology and the run config.
#include <memory>

#include "forcefields/settings.hpp"
#include "engine/force_field.hpp"
#include "engine/system.hpp"

namespace vimd {

std::unique_ptr<ForceField> make_force_field(const System& system, const ForceFieldConfig& config);

}  // namespace vimd
