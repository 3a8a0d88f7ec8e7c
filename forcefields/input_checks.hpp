#pragma once
// The force field's settings checked against the system and box a run reads (engine/input.hpp's
// InputCheck): the box must hold the cut-off, PME's grid must fit in memory and be fine enough for
// its beta (docs/pme.md); warned, a pair list cut to the box and a net charge.
#include <string>
#include <vector>

#include "engine/box.hpp"
#include "engine/config.hpp"
#include "engine/system.hpp"

namespace vimd {

std::vector<std::string> check_force_field_input(const RunConfig& config, const System& system, const Box& box,
                                                 int box_line);

}  // namespace vimd
