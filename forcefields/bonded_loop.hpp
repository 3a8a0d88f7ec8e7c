#pragma once
// The OpenMP loop shared by the bonded terms (bonds, angles, dihedrals, 1–4 pairs): items are taken in fixed blocks,
// each thread adds into its own buffer, and the buffers are summed in thread order; per-block
// energies are summed in block order, so energies do not depend on the thread count and vectors
// differ by round-off only. Small lists run serially (the buffers would cost more than the work).
#include <omp.h>

#include <algorithm>
#include <array>
#include <type_traits>
#include <vector>

#include "engine/types.hpp"

namespace vimd {

class BondedLoop {
 public:
  // body(item, Coords& out) adds item's contribution to out and returns its energy: a double, or
  // a std::array<double, N> for a term with N energies. Returns the total energy (of the same
  // type); contributions are added to out.
  template <class Body>
  auto run(int n_items, Coords& out, Body&& body) {
    using Energy = std::invoke_result_t<Body&, int, Coords&>;
    constexpr int kBlock = 256;
    const int n_blocks = (n_items + kBlock - 1) / kBlock;
    block_energy_.assign(n_blocks * kComponents<Energy>, 0.0);
    auto run_block = [&](int b, Coords& target) {
      Energy e{};
      for (int i = b * kBlock; i < std::min(n_items, (b + 1) * kBlock); ++i) add(e, body(i, target));
      store(e, &block_energy_[b * kComponents<Energy>]);
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
    Energy energy{};
    for (int b = 0; b < n_blocks; ++b) {
      Energy e;
      load(&block_energy_[b * kComponents<Energy>], e);
      add(energy, e);
    }
    return energy;
  }

 private:
  template <class Energy>
  static constexpr int kComponents = static_cast<int>(sizeof(Energy) / sizeof(double));
  static void add(double& sum, double x) { sum += x; }
  template <std::size_t N>
  static void add(std::array<double, N>& sum, const std::array<double, N>& x) {
    for (std::size_t k = 0; k < N; ++k) sum[k] += x[k];
  }
  static void store(double e, double* to) { *to = e; }
  template <std::size_t N>
  static void store(const std::array<double, N>& e, double* to) { std::copy(e.begin(), e.end(), to); }
  static void load(const double* from, double& e) { e = *from; }
  template <std::size_t N>
  static void load(const double* from, std::array<double, N>& e) { std::copy(from, from + N, e.begin()); }

  static constexpr int kParallelThreshold = 2048;
  std::vector<Coords> buffers_;
  std::vector<double> block_energy_;
};

}  // namespace vimd
