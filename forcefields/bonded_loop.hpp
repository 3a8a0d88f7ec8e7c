#pragma once
// The OpenMP loop shared by the bonded terms (bonds, angles): items are taken in fixed blocks,
// each thread adds into its own buffer, and the buffers are summed in thread order; per-block
// energies are summed in block order, so energies do not depend on the thread count and vectors
// differ by round-off only. Small lists run serially (the buffers would cost more than the work).
#include <omp.h>

#include <algorithm>
#include <vector>

#include "engine/types.hpp"

namespace vimd {

class BondedLoop {
 public:
  // body(item, Coords& out) adds item's contribution to out and returns its energy. Returns the
  // total energy; contributions are added to out.
  template <class Body>
  double run(int n_items, Coords& out, Body&& body) {
    constexpr int kBlock = 256;
    const int n_blocks = (n_items + kBlock - 1) / kBlock;
    block_energy_.assign(n_blocks, 0.0);
    auto run_block = [&](int b, Coords& target) {
      double e = 0;
      for (int i = b * kBlock; i < std::min(n_items, (b + 1) * kBlock); ++i) e += body(i, target);
      block_energy_[b] = e;
    };
    if (n_items < kParallelThreshold || omp_get_max_threads() == 1) {
      for (int b = 0; b < n_blocks; ++b) run_block(b, out);
    } else {
      buffers_.resize(omp_get_max_threads());
#pragma omp parallel
      {
        const int t = omp_get_thread_num(), nt = omp_get_num_threads();
        Coords& mine = buffers_[t];
        mine.setZero(3, out.cols());
        for (int b = t; b < n_blocks; b += nt) run_block(b, mine);
#pragma omp barrier
#pragma omp for schedule(static)
        for (Eigen::Index a = 0; a < out.cols(); ++a)
          for (int k = 0; k < nt; ++k) out.col(a) += buffers_[k].col(a);
      }
    }
    double energy = 0;
    for (double e : block_energy_) energy += e;
    return energy;
  }

 private:
  static constexpr int kParallelThreshold = 2048;
  std::vector<Coords> buffers_;
  std::vector<double> block_energy_;
};

}  // namespace vimd
