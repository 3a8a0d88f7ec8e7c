// Benchmark (prints figures, asserts nothing, not a test): the Ewald mesh alone on the system of a
// run file, for a grid, order and β given on the command line: its energy ("coulomb_recip", to
// compare with GROMACS's Coul. recip.) and the cost of one force evaluation and one Hessian–vector
// product, in double and in single precision, on the OpenMP threads asked for (best of several
// batches; for instruction counts run it under callgrind with one batch and read the inclusive
// counts of forces_ms and hessian_vector_ms).
//   cmake --build build --target bench_ewald_mesh
//   build/bench_ewald_mesh inputs/water900/run.toml 28 28 28 4 3.4693 [CALLS] [BATCHES]
#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <random>

#include "app/run_schema.hpp"
#include "engine/input.hpp"
#include "forcefields/input_checks.hpp"
#include "forcefields/ewald_mesh.hpp"

namespace {

double now_ms() {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

template <class F>
double best_ms(int batches, int calls, F&& f) {
  double best = INFINITY;
  for (int batch = 0; batch < batches; ++batch) {
    const double t0 = now_ms();
    for (int c = 0; c < calls; ++c) f();
    best = std::min(best, (now_ms() - t0) / calls);
  }
  return best;
}

// Separate functions, so that a profile (callgrind's inclusive counts) tells the three and the two
// precisions apart.
template <bool single>
[[gnu::noinline]] double forces_ms(vimd::EwaldMeshTerm& term, const vimd::Coords& q, vimd::Coords& f, int batches,
                                   int calls) {
  return best_ms(batches, calls, [&] { term.add_forces(q, f, {}); });
}

// A force pass and a product: at q (the product takes the pass's potential grid) or elsewhere
// (the product computes its own).
template <bool single, bool after_forces_at_q>
[[gnu::noinline]] double hessian_vector_ms(vimd::EwaldMeshTerm& term, const vimd::Coords& q, const vimd::Coords& u,
                                           vimd::Coords& hu, int batches, int calls) {
  const vimd::Coords q_moved = q.array() + 1e-9;
  const vimd::Coords& at = after_forces_at_q ? q : q_moved;
  vimd::Coords f = vimd::Coords::Zero(3, q.cols());
  return best_ms(batches, calls, [&] {
    term.add_forces(at, f, {});
    term.add_hessian_vector(q, u, hu);
  });
}

template <bool single>
void measure(const vimd::System& system, const vimd::EwaldMeshParameters& p, const vimd::Coords& q,
             const vimd::Coords& u, int batches, int calls) {
  vimd::EwaldMeshTerm term(system, p, single);
  vimd::Coords f = vimd::Coords::Zero(3, q.cols()), hu = f;
  double e = 0;
  term.add_forces(q, f, std::span<double>(&e, 1));
  term.add_hessian_vector(q, u, hu);  // plans made: not measured
  std::printf("%s: coulomb_recip %.12g kJ/mol (net-charge term %.6g)\n", single ? "single" : "double", e,
              term.net_charge_energy());
  const double force_ms = forces_ms<single>(term, q, f, batches, calls);
  const double alone_ms = hessian_vector_ms<single, false>(term, q, u, hu, batches, calls) - force_ms;
  const double after_ms = hessian_vector_ms<single, true>(term, q, u, hu, batches, calls) - force_ms;
  std::printf("  forces %.3f ms, HVP alone %.3f ms, HVP after a force pass at q %.3f ms\n", force_ms, alone_ms,
              after_ms);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 7 || argc > 9) {
    std::fprintf(stderr, "usage: %s RUN.toml NX NY NZ ORDER BETA [CALLS [BATCHES]]\n", argv[0]);
    return 2;
  }
  const vimd::RunInput input = vimd::read_run_input(argv[1], vimd::run_schema(), {}, vimd::check_force_field_input);
  const vimd::EwaldMeshParameters p{{std::atoi(argv[2]), std::atoi(argv[3]), std::atoi(argv[4])},
                                    std::atoi(argv[5]),
                                    std::atof(argv[6]),
                                    vimd::kCoulomb};
  const int calls = argc > 7 ? std::atoi(argv[7]) : 10, batches = argc > 8 ? std::atoi(argv[8]) : 5;
  const vimd::Coords& q = input.state.q;
  std::mt19937_64 rng(1);
  std::normal_distribution<double> normal(0.0, 1.0);
  vimd::Coords u(3, q.cols());
  for (int i = 0; i < q.cols(); ++i)
    for (int k = 0; k < 3; ++k) u(k, i) = normal(rng);

  std::printf("%d atoms, grid %d x %d x %d, order %d, beta %.10g /nm, %d threads\n", input.system.n_atoms(), p.grid[0],
              p.grid[1], p.grid[2], p.order, p.beta, omp_get_max_threads());
  measure<false>(input.system, p, q, u, batches, calls);
  measure<true>(input.system, p, q, u, batches, calls);
}
