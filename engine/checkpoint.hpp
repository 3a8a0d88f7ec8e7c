#pragma once
// state.cpt: everything a stopped run needs to go on bit-identically: the State (forces and
// energies included), the integrator's and the force terms' carried state, the observers' (file
// sizes to truncate back to, sampled series), the totals so far, an identity (config and resolved
// system) a continuation must match, and where each segment of the run ran. Written atomically (to
// NAME.new, fsync, rename, fsync dir) and ending with a checksum over all bytes before it.
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include "engine/carried.hpp"
#include "engine/state.hpp"

namespace vimd {

// What a continued run must share with the stopped one, as (what, value) in a fixed order.
using RunIdentity = std::vector<std::pair<std::string, std::string>>;

// Facts about where a run runs, as (what, value): SIMD target, precision, threads.
using Platform = std::vector<std::pair<std::string, std::string>>;

// One process's share of a run: the step it started from and the platform it ran on.
struct RunSegment {
  long first_step = 0;
  Platform platform;
};

struct Checkpoint {
  RunIdentity identity;
  long first_step = 0, last_step = 0;  // the run's span; state.step lies between
  State state;
  Carried integrator, force_field, totals;
  std::vector<Carried> observers;  // in the order they were added to the Simulation
  std::vector<RunSegment> segments;  // every process's so far, the one that wrote it last
};

void write_checkpoint(const std::filesystem::path& file, const Checkpoint& checkpoint);
// InputError naming the file when it is missing, truncated, damaged (its checksum does not match),
// written by an older vimd (no checksum) or not a vimd checkpoint.
Checkpoint read_checkpoint(const std::filesystem::path& file);
// The checksum a checkpoint ends with, of its n bytes before it (for tests that build one).
std::uint64_t checkpoint_checksum(const void* data, std::size_t n);
// InputError listing every entry that differs ("dt: 0.002 in the checkpoint, 0.001 here").
void check_identity(const std::filesystem::path& file, const RunIdentity& checkpoint, const RunIdentity& here);

}  // namespace vimd
