#include "engine/thread_pinning.hpp"

#include <omp.h>
#include <pthread.h>
#include <sched.h>
#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <fstream>
#include <map>
#include <stdexcept>
#include <utility>

namespace vimd {

PinMode parse_pin_mode(const std::string& text) {
  if (text == "auto") return PinMode::automatic;
  if (text == "on") return PinMode::on;
  if (text == "off") return PinMode::off;
  throw std::invalid_argument("pinning \"" + text + "\": expected auto, on or off");
}

namespace {

// A topology number of `cpu` from sysfs, or -1 where the kernel does not say.
int topology_number(int cpu, const char* name) {
  std::ifstream in("/sys/devices/system/cpu/cpu" + std::to_string(cpu) + "/topology/" + name);
  int value = -1;
  return in >> value ? value : -1;
}

cpu_set_t process_cpu_set() {
  cpu_set_t set;
  CPU_ZERO(&set);
  if (sched_getaffinity(0, sizeof set, &set) != 0) CPU_ZERO(&set);
  return set;
}

std::vector<int> allowed_cpus() {
  const cpu_set_t set = process_cpu_set();
  std::vector<int> cpus;
  for (int cpu = 0; cpu < CPU_SETSIZE; ++cpu)
    if (CPU_ISSET(cpu, &set)) cpus.push_back(cpu);
  return cpus;
}

// Each of the pool's first `threads` threads onto set_of(t); whether every one took it.
template <class SetOf>
bool set_thread_affinities(int threads, SetOf&& set_of) {
  std::vector<int> failed(threads, 0);
#pragma omp parallel num_threads(threads)
  {
    const int t = omp_get_thread_num();
    const cpu_set_t set = set_of(t);
    failed[t] = pthread_setaffinity_np(pthread_self(), sizeof set, &set);
  }
  return std::none_of(failed.begin(), failed.end(), [](int e) { return e != 0; });
}

std::string cpu_list(const std::vector<int>& cpus) {
  std::string text;
  for (int cpu : cpus) text += (text.empty() ? "" : ",") + std::to_string(cpu);
  return text;
}

}  // namespace

std::vector<int> pinning_order() {
  const std::vector<int> cpus = allowed_cpus();
  // Rank 0 for a core's first hardware thread in CPU order, 1 for its second, ...
  std::map<std::pair<int, int>, int> seen;
  std::vector<std::pair<int, int>> rank_cpu;
  for (int cpu : cpus) {
    const std::pair<int, int> core{topology_number(cpu, "physical_package_id"), topology_number(cpu, "core_id")};
    const int rank = core.second < 0 ? 0 : seen[core]++;
    rank_cpu.emplace_back(rank, cpu);
  }
  std::sort(rank_cpu.begin(), rank_cpu.end());
  std::vector<int> order;
  for (const auto& [rank, cpu] : rank_cpu) order.push_back(cpu);
  return order;
}

ThreadPinning pin_threads(PinMode mode, int threads) {
  ThreadPinning result;
  auto unpinned = [&](const std::string& why) {
    result.description = "no (" + why + ")";
    return result;
  };
  if (mode == PinMode::off) return unpinned("pinning off");
  for (const char* variable : {"OMP_PROC_BIND", "OMP_PLACES", "GOMP_CPU_AFFINITY"})
    if (std::getenv(variable)) return unpinned(std::string(variable) + " is set");
  const std::vector<int> order = pinning_order();
  const int allowed = static_cast<int>(order.size());
  const long online = sysconf(_SC_NPROCESSORS_ONLN);
  const std::string threads_on_cpus = std::to_string(threads) + " thread" + (threads == 1 ? "" : "s") + " on " +
                                      std::to_string(allowed) + " CPU" + (allowed == 1 ? "" : "s");
  if (threads > allowed) return unpinned("more threads than CPUs: " + threads_on_cpus);
  if (mode == PinMode::automatic) {
    if (allowed < online) return unpinned("auto: the process may use " + std::to_string(allowed) + " of " +
                                          std::to_string(online) + " CPUs, placed from outside");
    if (threads < allowed) return unpinned("auto: " + threads_on_cpus);
  }
  const cpu_set_t everywhere = process_cpu_set();
  const bool pinned = set_thread_affinities(threads, [&](int t) {
    cpu_set_t one;
    CPU_ZERO(&one);
    CPU_SET(order[t], &one);
    return one;
  });
  if (!pinned) {
    // No thread stays pinned where some could not be.
    set_thread_affinities(threads, [&](int) { return everywhere; });
    return unpinned("the system refused to pin the threads");
  }
  result.cpus.assign(order.begin(), order.begin() + threads);
  result.description = threads == 1 ? "CPU " : "CPUs ";
  result.description += cpu_list(result.cpus);
  return result;
}

}  // namespace vimd
