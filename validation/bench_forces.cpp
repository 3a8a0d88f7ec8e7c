// Benchmark (prints figures, asserts nothing, not a test): cost of one force evaluation (forces
// only, as on most steps, and with energies), one
// Hessian–vector product (with and without the force pass's cut-off masks), one neighbour-list
// build and one pruning of the searched list for the system of a run file, on 1 and 2 OpenMP
// threads; best of several batches. The prunings alternate between the positions the run file's
// velocities give 0.01 and 0.03 ps on (further apart than half the skin, within the searched
// list's reach for the usual atomic speeds), so that atoms have moved unevenly, as in a run.
//   cmake --build build --target bench_forces && build/bench_forces inputs/water4000/run.toml [SIMD_TARGET]
#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <random>

#include "app/run_schema.hpp"
#include "engine/input.hpp"
#include "forcefields/input_checks.hpp"
#include "forcefields/nonbonded/neighbor_list.hpp"
#include "forcefields/nonbonded/nonbonded_kernels.hpp"
#include "forcefields/nonbonded/nonbonded_pair_term.hpp"
#include "forcefields/registry.hpp"
#include "simd/targets.hpp"

namespace {

double now_ms() {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

// Best per-call wall time over batches: the machine is shared, so the minimum is the cost.
template <class F>
double best_ms(int calls, F&& f) {
  double best = INFINITY;
  for (int batch = 0; batch < 7; ++batch) {
    const double t0 = now_ms();
    for (int c = 0; c < calls; ++c) f();
    best = std::min(best, (now_ms() - t0) / calls);
  }
  return best;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2 && argc != 3) {
    std::fprintf(stderr, "usage: %s RUN.toml [SIMD_TARGET]\n", argv[0]);
    return 2;
  }
  if (argc == 3) vimd::simd::use_target(argv[2]);
  const vimd::RunInput input = vimd::read_run_input(argv[1], vimd::run_schema(), {}, vimd::check_force_field_input);
  const vimd::System& system = input.system;
  const vimd::Coords& q = input.state.q;
  const vimd::ForceFieldConfig& ff = vimd::forcefield_config(input.config);
  std::mt19937_64 rng(1);
  std::normal_distribution<double> normal(0.0, 1.0);
  vimd::Coords u(3, q.cols());
  for (int i = 0; i < q.cols(); ++i)
    for (int k = 0; k < 3; ++k) u(k, i) = normal(rng);

  std::printf("SIMD %s (%d doubles per vector)\n", vimd::simd::target_name().c_str(), vimd::simd::lanes());
  std::printf("%d atoms, cutoff %.3f nm, skin %.3f nm, %s, %s\n", system.n_atoms(), ff.cutoff, ff.neighbor_skin,
              ff.vdw_modifier.c_str(), ff.coulomb.c_str());
  const vimd::Coords q_early = q + 0.01 * input.state.v, q_late = q + 0.03 * input.state.v;
  std::printf("%-8s%14s%18s%22s%16s%16s%12s\n", "threads", "forces ms", "+energies ms", "HVP after forces ms",
              "HVP alone ms", "list build ms", "prune ms");
  for (int threads : {1, 2}) {
    omp_set_num_threads(threads);
    auto field = vimd::make_force_field(system, ff);
    vimd::Forces forces;
    vimd::Coords hu;
    field->compute(q, forces);
    const double force_ms = best_ms(10, [&] { field->compute_forces(q, forces); });
    const double energies_ms = best_ms(10, [&] { field->compute(q, forces); });
    field->hessian_vector(q, u, hu);  // from here on force passes keep their cut-off masks
    field->compute(q, forces);
    const double hvp_reuse_ms = best_ms(10, [&] { field->hessian_vector(q, u, hu); });
    auto cold = vimd::make_force_field(system, ff);
    cold->hessian_vector(q, u, hu);
    const double hvp_ms = best_ms(10, [&] { cold->hessian_vector(q, u, hu); });
    vimd::NeighborList list(system.box, ff.cutoff, ff.neighbor_skin, system.exclusions);
    const double build_ms = best_ms(3, [&] { list.build(q); });
    // The searched list's own time per pruning, from the work counters: no search in between.
    auto pruned = vimd::make_force_field(system, ff);
    pruned->compute_forces(q, forces);
    double prune_ms = INFINITY;
    for (int batch = 0; batch < 7; ++batch) {
      const vimd::WorkCounters before = pruned->work();
      for (int c = 0; c < 5; ++c) {
        pruned->compute_forces(q_early, forces);
        pruned->compute_forces(q_late, forces);
      }
      const vimd::WorkCounters done = pruned->work() - before;
      if (done.neighbor_rebuilds != 0 || done.neighbor_prunes == 0) {
        std::fprintf(stderr,
                     "bench_forces: the prunings searched again (%ld searches, %ld prunings): atoms too fast for "
                     "the search skin\n",
                     done.neighbor_rebuilds, done.neighbor_prunes);
        return 1;
      }
      prune_ms = std::min(prune_ms, 1e3 * done.neighbor_build_seconds / done.neighbor_prunes);
    }
    std::printf("%-8d%14.3f%18.3f%22.3f%16.3f%16.3f%12.3f\n", threads, force_ms, energies_ms, hvp_reuse_ms, hvp_ms,
                build_ms, prune_ms);
  }
}
