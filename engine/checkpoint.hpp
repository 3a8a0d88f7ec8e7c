#pragma once
// state.cpt: everything a stopped run needs to go on bit-identically: the State (forces and
// energies included), the integrator's and the force terms' carried state, the observers' (file
// sizes to truncate back to, sampled series), the totals so far, and an identity (config and
// system) a continuation must match. Written atomically: to NAME.new, fsync, rename, fsync dir.
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include "engine/carried.hpp"
#include "engine/state.hpp"

namespace vimd {

// What a continued run must share with the stopped one, as (what, value) in a fixed order.
using RunIdentity = std::vector<std::pair<std::string, std::string>>;

struct Checkpoint {
  RunIdentity identity;
  long first_step = 0, last_step = 0;  // the run's span; state.step lies between
  State state;
  Carried integrator, force_field, totals;
  std::vector<Carried> observers;  // in the order they were added to the Simulation
};

void write_checkpoint(const std::filesystem::path& file, const Checkpoint& checkpoint);
// InputError naming the file when it is missing, truncated or not a vimd checkpoint.
Checkpoint read_checkpoint(const std::filesystem::path& file);
// InputError listing every entry that differs ("dt: 0.002 in the checkpoint, 0.001 here").
void check_identity(const std::filesystem::path& file, const RunIdentity& checkpoint, const RunIdentity& here);

}  // namespace vimd
