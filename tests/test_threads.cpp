// Thread-count agreement: energies, forces and Hessian–vector products with 1 and 2 OpenMP
// threads agree to 1e-12 relative for every LJ modifier and Coulomb kind, and the neighbour list
// itself does not depend on the thread count. Pinned threads stay on their CPUs.
#include <gtest/gtest.h>
#include <omp.h>
#include <pthread.h>
#include <sched.h>

#include <algorithm>
#include <cstdlib>
#include <random>

#include "forcefields/nonbonded/neighbor_list.hpp"
#include "engine/thread_pinning.hpp"
#include "forcefields/dihedral_term.hpp"
#include "forcefields/harmonic_angle.hpp"
#include "forcefields/harmonic_bond.hpp"
#include "forcefields/nonbonded/nonbonded_pair_term.hpp"
#include "forcefields/nonbonded/pair_lists.hpp"
#include "forcefields/pairs_14.hpp"
#include "forcefields/registry.hpp"
#include "test_ff_systems.hpp"

namespace vimd {
namespace {

struct Evaluation {
  Forces forces;
  Coords hu;
};

Evaluation evaluate_with_threads(int threads, const System& system, const Coords& q, const Coords& u,
                                 const ForceFieldConfig& config) {
  omp_set_num_threads(threads);
  int seen = 0;
#pragma omp parallel
#pragma omp single
  seen = omp_get_num_threads();
  EXPECT_EQ(seen, threads);
  auto field = make_force_field(system, config);
  Evaluation e;
  field->compute(q, e.forces);
  field->hessian_vector(q, u, e.hu);
  return e;
}

class ThreadAgreement : public ::testing::TestWithParam<std::tuple<std::string, std::string>> {
 protected:
  void TearDown() override { omp_set_num_threads(omp_get_num_procs()); }
};

// 4500 atoms: enough for every parallel loop (list build, packing, pair loop) to use the threads.
TEST_P(ThreadAgreement, OneAndTwoThreadsAgree) {
  const auto [modifier, coulomb] = GetParam();
  auto [system, q] = testing::water_like_system(1500, Vec3(3.9, 3.8, 4.0), 77);
  std::mt19937_64 rng(1);
  std::normal_distribution<double> normal(0.0, 1.0);
  Coords u(3, q.cols());
  for (int i = 0; i < q.cols(); ++i)
    for (int k = 0; k < 3; ++k) u(k, i) = normal(rng);
  const auto config = testing::pair_config(modifier, coulomb, 78.0);
  const Evaluation one = evaluate_with_threads(1, system, q, u, config);
  const Evaluation two = evaluate_with_threads(2, system, q, u, config);
  ASSERT_EQ(one.forces.terms.size(), two.forces.terms.size());
  // The energies are summed from per-cluster partials in a fixed order: identical, not just close.
  for (std::size_t k = 0; k < one.forces.terms.size(); ++k) EXPECT_EQ(one.forces.terms[k], two.forces.terms[k]) << k;
  EXPECT_NEAR(one.forces.potential, two.forces.potential, 1e-12 * std::abs(one.forces.potential));
  EXPECT_LT(testing::relative_difference(two.forces.f, one.forces.f), 1e-12);
  EXPECT_LT(testing::relative_difference(two.hu, one.hu), 1e-12);
  // Per atom, not only in norm.
  EXPECT_LT((two.forces.f - one.forces.f).cwiseAbs().maxCoeff(), 1e-12 * one.forces.f.cwiseAbs().maxCoeff());
  EXPECT_LT((two.hu - one.hu).cwiseAbs().maxCoeff(), 1e-12 * one.hu.cwiseAbs().maxCoeff());
}

INSTANTIATE_TEST_SUITE_P(AllModifiersAndCoulombKinds, ThreadAgreement,
                         ::testing::Combine(::testing::Values("none", "potential-shift", "force-switch",
                                                              "potential-switch"),
                                            ::testing::Values("reaction-field", "cutoff", "none")),
                         [](const auto& info) {
                           std::string name = std::get<0>(info.param) + "_" + std::get<1>(info.param);
                           for (char& ch : name)
                             if (ch == '-') ch = '_';
                           return name;
                         });

// The bonded terms go parallel above a few thousand items: check them on their own.
TEST(ThreadAgreementBonded, BondedTermsAgree) {
  auto [system, positions] = testing::water_like_system(2500, Vec3(4.6, 4.5, 4.7), 79, Vec3::Zero(), 0.25);
  ASSERT_GE(system.angles.size(), 2500u);
  std::mt19937_64 rng(2);
  std::normal_distribution<double> normal(0.0, 1.0);
  const auto random_direction = [&](Eigen::Index n) {
    Coords u(3, n);
    for (Eigen::Index i = 0; i < n; ++i)
      for (int k = 0; k < 3; ++k) u(k, i) = normal(rng);
    return u;
  };
  const Coords water_u = random_direction(positions.cols());
  HarmonicBondTerm bonds(system.bonds, system.box);
  HarmonicAngleTerm angles(system.angles, system.box);
  auto [chains, chain_q] = testing::chain_system(700, 7, Vec3(4.0, 4.0, 4.0), 80);
  ASSERT_GE(chains.pairs14.size(), 2800u);
  const Coords chain_u = random_direction(chain_q.cols());
  DihedralTerm dihedrals(chains);
  Pair14Term pairs(chains.pairs14, chains.box, ForceFieldConfig{});
  for (ForceTerm* term : {static_cast<ForceTerm*>(&bonds), static_cast<ForceTerm*>(&angles),
                          static_cast<ForceTerm*>(&dihedrals), static_cast<ForceTerm*>(&pairs)}) {
    const bool chain = term == &dihedrals || term == &pairs;
    const Coords& q = chain ? chain_q : positions;
    const Coords& u = chain ? chain_u : water_u;
    omp_set_num_threads(1);
    const auto one = testing::evaluate(*term, q);
    const Coords hu_one = testing::hessian_vector(*term, q, u);
    omp_set_num_threads(2);
    const auto two = testing::evaluate(*term, q);
    const Coords hu_two = testing::hessian_vector(*term, q, u);
    omp_set_num_threads(omp_get_num_procs());
    EXPECT_EQ(one.energy, two.energy) << term->energy_names()[0];
    EXPECT_LT(testing::relative_difference(two.f, one.f), 1e-12) << term->energy_names()[0];
    EXPECT_LT(testing::relative_difference(hu_two, hu_one), 1e-12) << term->energy_names()[0];
  }
}

TEST(ThreadAgreementList, NeighborListDoesNotDependOnThreadCount) {
  auto [system, q] = testing::water_like_system(1500, Vec3(3.9, 3.8, 4.0), 78);
  auto build = [&](int threads) {
    omp_set_num_threads(threads);
    NeighborList list(system.box, 0.9, 0.1, system.exclusions);
    list.build(q);
    return list;
  };
  const NeighborList one = build(1), two = build(2);
  omp_set_num_threads(omp_get_num_procs());
  EXPECT_EQ(one.slot_atom(), two.slot_atom());
  EXPECT_EQ(one.half_start(), two.half_start());
  ASSERT_EQ(one.entries().size(), two.entries().size());
  for (std::size_t e = 0; e < one.entries().size(); ++e) {
    EXPECT_EQ(one.entries()[e].j_cluster(), two.entries()[e].j_cluster());
    EXPECT_EQ(one.entries()[e].shift(), two.entries()[e].shift());
    EXPECT_EQ(one.entries()[e].mask, two.entries()[e].mask);
    EXPECT_EQ(one.nearest()[e], two.nearest()[e]);
  }
}

// The pair loop's segments: every half once, in order, each segment a contiguous run; each
// boundary within half a chunk of its place, so a home segment is within a chunk of its 1/nt of the
// home part of the entries and a tail of its 1/kTailDenominator, where the early halves hold far
// more entries than the late ones.
TEST(ThreadAgreementList, SegmentsCoverEveryHalfOnceInTheirShares) {
  std::mt19937 rng(3);
  for (int n_halves : {1, 7, 400, 1001}) {
    std::vector<int> half_start{0};
    for (int h = 0; h < n_halves; ++h)
      half_start.push_back(half_start.back() + std::uniform_int_distribution<int>(0, 2 * (n_halves - h) / 10 + 3)(rng));
    int heaviest_chunk = 0;
    for (int c = 0; c * kHalfChunk < n_halves; ++c)
      heaviest_chunk = std::max(heaviest_chunk, half_start[std::min(n_halves, (c + 1) * kHalfChunk)] -
                                                    half_start[c * kHalfChunk]);
    const double total = half_start.back();
    for (int nt : {1, 2, 3, 4}) {
      const int segments = pair_loop_segments(nt);
      EXPECT_EQ(segments, nt == 1 ? 1 : nt + kTailSegments);
      int next = 0;
      for (int s = 0; s < segments; ++s) {
        const std::string where = std::to_string(n_halves) + " halves, segment " + std::to_string(s) + " of " +
                                  std::to_string(segments) + ", " + std::to_string(nt) + " threads";
        long share = 0;
        bool first = true;
        for_segment_chunks(half_start, s, nt, [&](int h0, int h1) {
          EXPECT_EQ(h0, next) << where;
          if (first) {
            EXPECT_EQ(segment_first_half(half_start, s, nt), h0) << where;
            first = false;
          }
          EXPECT_LT(h0, h1);
          EXPECT_LE(h1 - h0, kHalfChunk);
          next = h1;
          share += half_start[h1] - half_start[h0];
        });
        const double home = static_cast<double>(kTailDenominator - kTailSegments) / kTailDenominator;
        const double expected = nt == 1 ? total : s < nt ? total * home / nt : total / kTailDenominator;
        EXPECT_LE(std::abs(share - expected), heaviest_chunk) << where;
      }
      EXPECT_EQ(next, n_halves);
    }
  }
}

// Each thread's CPU set, as the thread sees it, in a parallel region of `threads` threads.
std::vector<std::vector<int>> thread_cpu_sets(int threads) {
  std::vector<std::vector<int>> sets(threads);
#pragma omp parallel num_threads(threads)
  {
    cpu_set_t set;
    CPU_ZERO(&set);
    pthread_getaffinity_np(pthread_self(), sizeof set, &set);
    for (int cpu = 0; cpu < CPU_SETSIZE; ++cpu)
      if (CPU_ISSET(cpu, &set)) sets[omp_get_thread_num()].push_back(cpu);
  }
  return sets;
}

// Clears the OpenMP affinity variables (tests/run.sh sets one) for the test's lifetime.
class PinThreads : public ::testing::Test {
 protected:
  void SetUp() override {
    for (const char* name : kAffinityVariables)
      if (const char* value = std::getenv(name)) saved_.emplace_back(name, value);
    for (const char* name : kAffinityVariables) unsetenv(name);
  }
  void TearDown() override {
    for (const auto& [name, value] : saved_) setenv(name.c_str(), value.c_str(), 1);
  }

 private:
  static constexpr const char* kAffinityVariables[] = {"OMP_PROC_BIND", "OMP_PLACES", "GOMP_CPU_AFFINITY"};
  std::vector<std::pair<std::string, std::string>> saved_;
};

TEST_F(PinThreads, PinnedThreadsKeepTheirCpusInLaterParallelRegions) {
  const std::vector<int> order = pinning_order();
  ASSERT_FALSE(order.empty());
  std::vector<int> sorted = order;
  std::sort(sorted.begin(), sorted.end());
  EXPECT_EQ(std::adjacent_find(sorted.begin(), sorted.end()), sorted.end()) << "a CPU twice in the pinning order";
  const int threads = std::min<int>(2, order.size());
  omp_set_num_threads(threads);
  const ThreadPinning pinning = pin_threads(PinMode::on, threads);
  ASSERT_EQ(pinning.cpus.size(), static_cast<std::size_t>(threads)) << pinning.description;
  // A region with fewer threads in between must not move the pool's threads.
#pragma omp parallel num_threads(1)
  { EXPECT_EQ(omp_get_thread_num(), 0); }
  for (int round = 0; round < 3; ++round) {
    const auto sets = thread_cpu_sets(threads);
    for (int t = 0; t < threads; ++t) EXPECT_EQ(sets[t], std::vector<int>{pinning.cpus[t]}) << "thread " << t;
  }
}

TEST_F(PinThreads, LeftAloneWhenOffOverbookedOrPlacedByTheEnvironment) {
  const int allowed = static_cast<int>(pinning_order().size());
  const std::vector<std::vector<int>> before = thread_cpu_sets(1);
  EXPECT_TRUE(pin_threads(PinMode::off, 1).cpus.empty());
  const ThreadPinning overbooked = pin_threads(PinMode::on, allowed + 1);
  EXPECT_TRUE(overbooked.cpus.empty());
  EXPECT_NE(overbooked.description.find("more threads than CPUs"), std::string::npos) << overbooked.description;
  if (allowed > 1) {  // auto pins only when the threads use every CPU
    const ThreadPinning fewer = pin_threads(PinMode::automatic, 1);
    EXPECT_TRUE(fewer.cpus.empty()) << fewer.description;
  }
  setenv("OMP_PLACES", "cores", 1);
  const ThreadPinning placed = pin_threads(PinMode::on, 1);
  unsetenv("OMP_PLACES");
  EXPECT_TRUE(placed.cpus.empty());
  EXPECT_NE(placed.description.find("OMP_PLACES"), std::string::npos) << placed.description;
  EXPECT_EQ(thread_cpu_sets(1), before);
  EXPECT_THROW(parse_pin_mode("yes"), std::invalid_argument);
}

}  // namespace
}  // namespace vimd
