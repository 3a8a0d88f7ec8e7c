#pragma once
// The run file's schema, assembled from the engine's keys and each component's: the one schema the
// reader, `vimd keys`, docs/run-file.md and a checkpoint's identity all use.
#include "engine/config_schema.hpp"

namespace vimd {

const ConfigSchema& run_schema();

}  // namespace vimd
