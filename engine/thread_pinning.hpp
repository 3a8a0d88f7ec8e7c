#pragma once
// Pinning the OpenMP threads to CPUs, as GROMACS's mdrun -pin does. Unpinned, the scheduler moves
// threads between CPUs, and a thread that shares a CPU for a while holds up every barrier of the
// step; pinned, each thread keeps its CPU and its caches.
#include <string>
#include <vector>

namespace vimd {

enum class PinMode {
  automatic,  // pin when the threads use every CPU of the machine (mdrun's -pin auto)
  on,         // pin whenever there are no more threads than CPUs this process may use
  off,
};

// "auto", "on", "off"; anything else throws std::invalid_argument.
PinMode parse_pin_mode(const std::string& text);

struct ThreadPinning {
  std::vector<int> cpus;  // thread t runs on cpus[t]; empty: not pinned
  std::string description;  // e.g. "CPUs 0,1" or "no (auto: 1 thread on 2 CPUs)"
};

// The CPUs this process may run on, one hardware thread of each core first (so that fewer threads
// than hardware threads spread over the cores), then in CPU order.
std::vector<int> pinning_order();

// Pins threads 0..threads-1 of the OpenMP thread pool to the first CPUs of pinning_order(), unless
// the mode or the environment says otherwise: an OpenMP affinity setting (OMP_PROC_BIND,
// OMP_PLACES, GOMP_CPU_AFFINITY) or a narrowed CPU set (taskset, a batch system's cgroup) means
// that someone placed the threads already, and auto leaves them. Later parallel regions of up to
// `threads` threads run on the same pool threads, hence on the same CPUs.
ThreadPinning pin_threads(PinMode mode, int threads);

}  // namespace vimd
