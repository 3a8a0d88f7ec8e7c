#pragma once
// The resolved system a run computes with, part by part, for a checkpoint's identity: every
// parameter, exclusion, constraint and virtual site as the topology reader resolved them, so a
// continue refuses a topology that reads differently (e.g. another nrexcl) and names the part.
#include "engine/checkpoint.hpp"
#include "engine/system.hpp"

namespace vimd {

// ("system: PART", "COUNT WHAT, fingerprint HEX") for each part of the System, then its box.
RunIdentity system_identity(const System& system);

}  // namespace vimd
