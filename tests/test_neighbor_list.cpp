// The cluster-pair Verlet list against its brute-force twin: an O(N²) minimum-image pair sum with
// the same kernels must give the same energies, forces and Hessian–vector products (1e-12; PME's
// double-precision forces 1e-11, see double_force_tolerance) over
// many displaced configurations, including displacements just below and just above half the skin,
// for periodic, small, partly periodic and non-periodic boxes and for unwrapped coordinates.
#include <gtest/gtest.h>
#include <omp.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <optional>
#include <random>
#include <set>
#include <tuple>

#include "engine/errors.hpp"
#include "forcefields/nonbonded/neighbor_list.hpp"
#include "tests/pair_form_kernels.hpp"
#include "forcefields/nonbonded/nonbonded_pair_term.hpp"
#include "forcefields/nonbonded/pair_lists.hpp"
#include "test_ff_systems.hpp"
#include "simd/targets.hpp"

namespace vimd {
namespace {

// The scalar (double) instantiations of the pair kernels, from the build's static SIMD target.
using namespace vimd::HWY_NAMESPACE;
using testing::lj_energy_force;
using testing::lj_hessian;
using testing::rf_energy_force;
using testing::rf_hessian;
using testing::ewald_energy_force;
using testing::ewald_hessian;

using testing::relative_difference;

struct Reference {
  double lj = 0, coulomb = 0;
  // Σ|terms|: the random test systems' Coulomb sums cancel to a small fraction of their terms, so
  // agreement is judged relative to the size of what is summed, not of the small result.
  double lj_scale = 0, coulomb_scale = 0;
  Coords f, hu;
};

// pairs_at: a pair (not excluded) counts if it is inside the cut-off there (default: at q), as
// in a step started at pairs_at (ForceTerm::start_step) where the force jumps at the cut-off.
template <VdwModifier M>
Reference brute_force(const NonbondedPairTerm& term, const System& s, const Coords& q, const Coords& u,
                      const Coords* pairs_at = nullptr) {
  const LjConstants& lj = term.form<LjConstants>();
  const ReactionField& rf = term.form<ReactionField>();
  const EwaldRealSpace& ewald = term.form<EwaldRealSpace>();
  const double rc2 = lj.cutoff * lj.cutoff;
  const bool coulomb = rf.kind == CoulombKind::reaction_field || ewald.present();
  const double prefactor = ewald.present() ? ewald.prefactor : rf.prefactor;
  Reference ref;
  ref.f.setZero(3, q.cols());
  ref.hu.setZero(3, q.cols());
  for (int i = 0; i < q.cols(); ++i) {
    if (coulomb) {
      const double self = ewald.present() ? ewald.self_energy(s.charge[i] * s.charge[i])
                                          : rf_self_energy(rf, s.charge[i] * s.charge[i]);
      ref.coulomb += self;
      ref.coulomb_scale += std::abs(self);
    }
    for (int j = i + 1; j < q.cols(); ++j) {
      const Vec3 d = s.box.minimum_image(q.col(i) - q.col(j));
      const double r2 = d.squaredNorm();
      const bool excluded = std::binary_search(s.exclusions[i].begin(), s.exclusions[i].end(), j);
      // Excluded pairs (the reaction-field or Ewald correction) always go by their current distance.
      const bool fixed = pairs_at && !excluded;
      const bool counts =
          fixed ? s.box.minimum_image(pairs_at->col(i) - pairs_at->col(j)).squaredNorm() < rc2 : r2 < rc2;
      if (!counts) continue;
      const double qq = prefactor * s.charge[i] * s.charge[j];
      const Vec3 du = u.col(i) - u.col(j);
      double v = 0, g = 0, a = 0, b = 0;
      if (excluded) {
        if (!coulomb) continue;
        if (ewald.present()) {
          ewald_excluded_energy_force(ewald, qq, r2, v, g);
          ewald_excluded_hessian(ewald, qq, r2, a, b);
        } else {
          rf_excluded_energy_force(rf, qq, r2, v, g);
          rf_excluded_hessian(rf, qq, r2, a, b);
        }
        ref.coulomb += v;
        ref.coulomb_scale += std::abs(v);
      } else {
        const double r = std::sqrt(r2);
        lj_energy_force<M>(lj, s.c6(s.type[i], s.type[j]), s.c12(s.type[i], s.type[j]), 1 / r2, r, v, g);
        lj_hessian<M>(lj, s.c6(s.type[i], s.type[j]), s.c12(s.type[i], s.type[j]), 1 / r2, r, a, b);
        ref.lj += v;
        ref.lj_scale += std::abs(v);
        if (coulomb) {
          double vc, gc, ac, bc;
          if (ewald.present() && ewald.modifier == EwaldModifier::potential_switch) {
            ewald_energy_force<EwaldModifier::potential_switch>(ewald, qq, 1 / r, r2, vc, gc);
            ewald_hessian<EwaldModifier::potential_switch>(ewald, qq, 1 / r, r2, ac, bc);
          } else if (ewald.present()) {
            ewald_energy_force<EwaldModifier::shifted>(ewald, qq, 1 / r, r2, vc, gc);
            ewald_hessian<EwaldModifier::shifted>(ewald, qq, 1 / r, r2, ac, bc);
          } else if (rf.modifier == CoulombModifier::potential_switch) {
            rf_energy_force<CoulombModifier::potential_switch>(rf, qq, 1 / r, r2, vc, gc);
            rf_hessian<CoulombModifier::potential_switch>(rf, qq, 1 / r, r2, ac, bc);
          } else {
            rf_energy_force<CoulombModifier::none>(rf, qq, 1 / r, r2, vc, gc);
            rf_hessian<CoulombModifier::none>(rf, qq, 1 / r, r2, ac, bc);
          }
          ref.coulomb += vc;
          ref.coulomb_scale += std::abs(vc);
          g += gc;
          a += ac;
          b += bc;
        }
      }
      ref.f.col(i) += g * d;
      ref.f.col(j) -= g * d;
      const Vec3 h = a * du + b * d.dot(du) * d;
      ref.hu.col(i) += h;
      ref.hu.col(j) -= h;
    }
  }
  return ref;
}

Reference brute_force(const NonbondedPairTerm& term, const System& s, const Coords& q, const Coords& u,
                      const Coords* pairs_at = nullptr) {
  switch (term.form<LjConstants>().modifier) {
    case VdwModifier::none:
      return brute_force<VdwModifier::none>(term, s, q, u, pairs_at);
    case VdwModifier::potential_shift:
      return brute_force<VdwModifier::potential_shift>(term, s, q, u, pairs_at);
    case VdwModifier::force_switch:
      return brute_force<VdwModifier::force_switch>(term, s, q, u, pairs_at);
    case VdwModifier::potential_switch:
      return brute_force<VdwModifier::potential_switch>(term, s, q, u, pairs_at);
  }
  return {};
}

Coords random_vectors(int n, std::mt19937_64& rng, double length) {
  std::normal_distribution<double> normal(0.0, 1.0);
  Coords d(3, n);
  for (int i = 0; i < n; ++i) {
    Vec3 v(normal(rng), normal(rng), normal(rng));
    d.col(i) = length * v.normalized();
  }
  return d;
}

// PME's double-precision kernels subtract a force correction fitted to 7e-12 of the bare term
// (docs/pme.md) where the reference takes erfc; everything else agrees to rounding.
double double_force_tolerance(const NonbondedPairTerm& term) {
  return term.form<EwaldRealSpace>().rational_corrections ? 1e-11 : 1e-12;
}

// step: evaluate as that step's evaluations.
void expect_matches_brute_force(NonbondedPairTerm& term, const System& s, const Coords& q, const std::string& what,
                                const Coords* pairs_at = nullptr, TermStepState* step = nullptr) {
  std::mt19937_64 rng(99);
  const Coords u = random_vectors(static_cast<int>(q.cols()), rng, 1.0);
  const Reference ref = brute_force(term, s, q, u, pairs_at);
  TermEvaluation how;
  how.step = step;
  const auto got = testing::evaluate(term, q, how);
  const Coords hu = testing::hessian_vector(term, q, u, how);
  EXPECT_NEAR(got.energies[0], ref.lj, 1e-12 * ref.lj_scale) << what;
  EXPECT_NEAR(got.energies[1], ref.coulomb, 1e-12 * ref.coulomb_scale) << what;
  EXPECT_LT(relative_difference(got.f, ref.f), double_force_tolerance(term)) << what;
  EXPECT_LT(relative_difference(hu, ref.hu), 1e-12) << what;
  Coords forces_only = Coords::Zero(3, q.cols());
  term.add_forces(q, forces_only, {}, how);
  EXPECT_LT(relative_difference(forces_only, ref.f), double_force_tolerance(term)) << what << ", forces only";
  // Bit for bit: whether the energies are due must not change the trajectory.
  EXPECT_EQ((forces_only - got.f).cwiseAbs().maxCoeff(), 0.0) << what << ", forces only";
}

// precision = "mixed": energies and forces from the single-precision kernel, to float accuracy
// (relative 1e-6 of the summed magnitudes, 1e-5 of the force field); the Hessian–vector products stay double.
void expect_mixed_matches_brute_force(NonbondedPairTerm& term, const System& s, const Coords& q,
                                      const std::string& what) {
  std::mt19937_64 rng(99);
  const Coords u = random_vectors(static_cast<int>(q.cols()), rng, 1.0);
  const Reference ref = brute_force(term, s, q, u);
  const auto got = testing::evaluate(term, q);
  EXPECT_NEAR(got.energies[0], ref.lj, 1e-6 * ref.lj_scale) << what;
  EXPECT_NEAR(got.energies[1], ref.coulomb, 1e-6 * ref.coulomb_scale) << what;
  const double force_error = relative_difference(got.f, ref.f);
  EXPECT_LT(force_error, 1e-5) << what;
  EXPECT_GT(force_error, 1e-12) << what << ": no single-precision rounding at all, is the mixed kernel running?";
  Coords forces_only = Coords::Zero(3, q.cols());
  term.add_forces(q, forces_only, {});
  EXPECT_LT(relative_difference(forces_only, ref.f), 1e-5) << what << ", forces only";
  EXPECT_EQ((forces_only - got.f).cwiseAbs().maxCoeff(), 0.0) << what << ", forces only";
  EXPECT_LT(relative_difference(testing::hessian_vector(term, q, u), ref.hu), 1e-12) << what;
}

// Single-precision evaluations (the variational solve's first iteration): forces and Hessian–vector
// products from the single-precision kernels, to float accuracy; a product handed the masks of a
// force pass at the same positions takes them and gives the same result; and back in double, the
// double results again.
void expect_single_precision_matches_brute_force(NonbondedPairTerm& term, const System& s, const Coords& q,
                                                 const std::string& what) {
  std::mt19937_64 rng(98);
  const Coords u = random_vectors(static_cast<int>(q.cols()), rng, 1.0);
  const Reference ref = brute_force(term, s, q, u);
  ASSERT_TRUE(term.has_single_precision());
  TermEvaluation single;
  single.single_precision = true;
  const Coords hu = testing::hessian_vector(term, q, u, single);
  const double hessian_error = relative_difference(hu, ref.hu);
  EXPECT_LT(hessian_error, 1e-5) << what;
  EXPECT_GT(hessian_error, 1e-12) << what << ": no single-precision rounding, is the single-precision HVP running?";
  Coords f = Coords::Zero(3, q.cols());
  TermMasks masks;
  TermEvaluation single_keeping = single;
  single_keeping.keep_masks = &masks;
  term.add_forces(q, f, {}, single_keeping);
  const double force_error = relative_difference(f, ref.f);
  EXPECT_LT(force_error, 1e-5) << what;
  EXPECT_GT(force_error, 1e-12) << what << ": no single-precision rounding, are the single-precision forces running?";
  const long hits = term.reused_masks();
  TermEvaluation single_with_masks = single;
  single_with_masks.masks = &masks;
  EXPECT_EQ((testing::hessian_vector(term, q, u, single_with_masks) - hu).cwiseAbs().maxCoeff(), 0.0)
      << what << ", masks reused";
  EXPECT_EQ(term.reused_masks(), hits + 1) << what;
  // A double-precision product does not take single-precision masks.
  TermEvaluation double_with_masks;
  double_with_masks.masks = &masks;
  EXPECT_LT(relative_difference(testing::hessian_vector(term, q, u, double_with_masks), ref.hu), 1e-12) << what;
  EXPECT_EQ(term.reused_masks(), hits + 1) << what;
  EXPECT_LT(relative_difference(testing::hessian_vector(term, q, u), ref.hu), 1e-12) << what << ", double again";
  f.setZero();
  term.add_forces(q, f, {});
  EXPECT_LT(relative_difference(f, ref.f), double_force_tolerance(term)) << what << ", double again";
  // A single-precision product after a double-precision force pass at new positions takes its masks.
  const Coords moved = q + random_vectors(static_cast<int>(q.cols()), rng, 1e-3);
  const Reference moved_ref = brute_force(term, s, moved, u);
  f.setZero();
  TermEvaluation keeping;
  keeping.keep_masks = &masks;
  term.add_forces(moved, f, {}, keeping);
  const long hits_before = term.reused_masks();
  const double moved_error =
      relative_difference(testing::hessian_vector(term, moved, u, single_with_masks), moved_ref.hu);
  EXPECT_LT(moved_error, 1e-5) << what << ", double-precision masks";
  EXPECT_GT(moved_error, 1e-12) << what << ", double-precision masks: is the single-precision HVP running?";
  EXPECT_EQ(term.reused_masks(), hits_before + 1) << what;
}

const char* const kModifiers[] = {"none", "potential-shift", "force-switch", "potential-switch"};

// The SIMD kernels with the Coulomb switch (from 0.05 nm: excluded pairs switched too) and a
// higher switch smoothness equal the pair-by-pair sum.
TEST(NeighborList, SwitchedCoulombMatchesBruteForce) {
  auto [system, q] = testing::water_like_system(300, Vec3(2.6, 2.5, 2.7), 23);
  for (const char* modifier : kModifiers) {
    auto config = testing::pair_config(modifier, "reaction-field", 78.0);
    config.coulomb_modifier = "potential-switch";
    config.coulomb_switch = 0.05;
    config.switch_smoothness = 5;
    NonbondedPairTerm term(system, config);
    expect_matches_brute_force(term, system, q, std::string(modifier) + " with switched Coulomb, k = 5");
  }
}

// Every atom moves by a fraction of the half skin at a time, with one list (search skin = skin)
// and with a searched list pruned to the skin: the list must be pruned exactly when someone has
// gone further than skin/2 since the last pruning, and searched again only when, at such a
// moment, someone has gone further than (search skin − skin)/2 since the last search.
TEST(NeighborList, MatchesBruteForceOverDisplacedConfigurations) {
  auto [system, q0] = testing::water_like_system(500, Vec3(3.0, 2.9, 3.1), 17);
  for (const char* modifier : kModifiers)
    for (const double search_skin : {0.1, 0.35}) {
      auto config = testing::pair_config(modifier, "reaction-field", 0.0);
      config.neighbor_search_skin = search_skin;
      NonbondedPairTerm term(system, config);
      const bool pruned = search_skin > config.neighbor_skin;
      const double half_skin = 0.5 * config.neighbor_skin;
      const double search_allowance = pruned ? 0.5 * (search_skin - config.neighbor_skin) : half_skin;
      const std::string what = std::string(modifier) + (pruned ? ", pruned" : ", one list");
      std::mt19937_64 rng(5);
      Coords q = q0, q_searched = q0, q_pruned = q0;
      long expected_searches = 1, expected_prunes = pruned ? 1 : 0;
      expect_matches_brute_force(term, system, q, what + " start");
      for (double fraction : {0.3, 0.6, 0.999, 0.4, 0.8, 1.001, 0.2, 1.2, 0.95, 0.05, 0.5, 1.5, 0.99, 0.7, 0.9, 1.1}) {
        q += random_vectors(static_cast<int>(q.cols()), rng, fraction * half_skin);
        if (max_displacement(q, pruned ? q_pruned : q_searched) > half_skin) {
          if (max_displacement(q, q_searched) > search_allowance) {
            ++expected_searches;
            q_searched = q;
          }
          if (pruned) ++expected_prunes;
          q_pruned = q;
        }
        expect_matches_brute_force(term, system, q, what + " step fraction " + std::to_string(fraction));
        EXPECT_EQ(testing::work(term).neighbor_rebuilds, expected_searches) << what << " after fraction " << fraction;
        EXPECT_EQ(testing::work(term).neighbor_prunes, expected_prunes) << what << " after fraction " << fraction;
      }
      EXPECT_GT(expected_searches, pruned ? 1 : 3) << what;
      if (pruned) {
        EXPECT_GT(expected_prunes, expected_searches + 3) << what;
      }
    }
}

// The same entries, half by half, in two regular lists.
void expect_same_regular_lists(const PairLists& one, const PairLists& two) {
  const PairListView a = one.regular(), b = two.regular();
  ASSERT_TRUE(std::equal(a.half_start.begin(), a.half_start.end(), b.half_start.begin(), b.half_start.end()));
  ASSERT_GT(a.size(), 0u);
  for (int h = 0; h + 1 < static_cast<int>(a.half_start.size()); ++h) {
    const NeighborList::Entry *in_a = a.entries_of(h), *in_b = b.entries_of(h);
    for (int k = 0; k < a.half_start[h + 1] - a.half_start[h]; ++k) {
      ASSERT_EQ(in_a[k].j_cluster(), in_b[k].j_cluster()) << "half " << h << " entry " << k;
      ASSERT_EQ(in_a[k].shift(), in_b[k].shift()) << "half " << h << " entry " << k;
      ASSERT_EQ(in_a[k].mask, in_b[k].mask) << "half " << h << " entry " << k;
    }
  }
}

// The searched list stays in the search's per-thread buffers, which a pruning finds again each
// time, and the pruned list in the pruning's: a copy of the lists reads its own, and goes on
// exactly as the original would, even once the original is gone.
TEST(NeighborList, CopiedListsPruneAsTheOriginalWould) {
  auto [system, q0] = testing::water_like_system(500, Vec3(3.0, 2.9, 3.1), 17);
  const double cutoff = 0.9, skin = 0.1, search_skin = 0.4;
  std::mt19937_64 rng(3);
  // Further than skin/2 for some atoms (a pruning), within (search_skin − skin)/2 (no search).
  const Coords q1 = q0 + random_vectors(static_cast<int>(q0.cols()), rng, 0.06);
  ASSERT_GT(max_displacement(q1, q0), 0.5 * skin);
  ASSERT_LT(max_displacement(q1, q0), 0.5 * (search_skin - skin));
  PairLists reference(system.box, cutoff, search_skin, skin, system.exclusions);
  std::optional<PairLists> original(std::in_place, system.box, cutoff, search_skin, skin, system.exclusions);
  reference.keep_regular(q0, false);
  original->keep_regular(q0, false);
  PairLists copy = *original;
  original.reset();
  expect_same_regular_lists(copy, reference);
  reference.keep_regular(q1, false);
  copy.keep_regular(q1, false);
  WorkCounters work;
  copy.add_work(work);
  EXPECT_EQ(work.neighbor_rebuilds, 1);
  EXPECT_EQ(work.neighbor_prunes, 2);
  expect_same_regular_lists(copy, reference);
}

// An entry packs the j-cluster and the shift into one word: the largest of each come back intact.
TEST(NeighborList, EntryKeepsTheLargestClusterAndShift) {
  using Entry = NeighborList::Entry;
  const int largest_cluster = (1 << Entry::kClusterBits) - 1, largest_shift = (1 << Entry::kShiftBits) - 1;
  for (const auto& [cluster, shift] : std::vector<std::pair<int, int>>{
           {0, 0}, {largest_cluster, 0}, {0, largest_shift}, {largest_cluster, largest_shift}, {12345, 13}}) {
    const Entry entry = Entry::make(cluster, shift, 0xdeadbeefu);
    EXPECT_EQ(entry.j_cluster(), cluster);
    EXPECT_EQ(entry.shift(), shift);
    EXPECT_EQ(entry.mask, 0xdeadbeefu);
  }
}

// Without neighbor_search_skin the searched list gets the skin plus a margin the box has room for
// (cut-off + search skin within half the box), and pruning only where that margin is at least the
// skin, so that searching waits longer than pruning does.
TEST(NeighborList, AutomaticSearchSkinFitsTheBox) {
  const std::vector<std::pair<double, double>> boxes{{4.0, 0.7}, {3.0, 0.6}, {2.5, 0.35}, {2.0, 0.1}};
  for (const auto& [box_length, expected] : boxes) {
    auto [system, q] = testing::water_like_system(100, Vec3::Constant(box_length), 3);
    const NonbondedPairTerm term(system, testing::pair_config("potential-shift", "reaction-field"));
    EXPECT_NEAR(term.search_skin(), expected, 1e-12) << "box " << box_length;
    EXPECT_EQ(term.skin(), 0.1);
  }
}

// Every SIMD target this CPU can run (an AVX-512 machine also runs the AVX2, SSE4 and portable
// paths) against the scalar brute force, for every LJ modifier with and without Coulomb, so that no
// target's kernels can rot unseen on a machine that would not choose them.
TEST(PairKernels, EveryAvailableSimdTargetMatchesTheScalarReference) {
  const std::vector<std::string> targets = simd::available_targets();
  ASSERT_FALSE(targets.empty());
  std::printf("SIMD targets tested: ");
  for (const auto& t : targets) std::printf("%s ", t.c_str());
  std::printf("(automatic choice: %s)\n", simd::target_name().c_str());
  auto [system, q] = testing::water_like_system(300, Vec3(2.5, 2.4, 2.6), 31);
  for (const std::string& target : targets) {
    simd::use_target(target);
    ASSERT_EQ(simd::target_name(), target);
    for (const char* coulomb : {"reaction-field", "pme", "none"})
      for (const char* modifier : kModifiers) {
        auto config = testing::pair_config(modifier, coulomb, 0.0);
        NonbondedPairTerm term(system, config);
        expect_matches_brute_force(term, system, q, target + " " + modifier + " " + coulomb);
        expect_single_precision_matches_brute_force(term, system, q, target + " single " + modifier + " " + coulomb);
        config.precision = "mixed";
        NonbondedPairTerm mixed_term(system, config);
        expect_mixed_matches_brute_force(mixed_term, system, q, target + " mixed " + modifier + " " + coulomb);
      }
    // Both switched: by the same S (one switch for the sum, 0.7 nm) and by different ones; PME's
    // real space switched.
    for (const char* coulomb : {"reaction-field", "pme"})
    for (double coulomb_switch : {0.7, 0.6}) {
      auto config = testing::pair_config("potential-switch", coulomb, 0.0);
      config.coulomb_modifier = "potential-switch";
      config.coulomb_switch = coulomb_switch;
      config.switch_smoothness = 4;
      NonbondedPairTerm term(system, config);
      const std::string what = " LJ and " + std::string(coulomb) + " switched, Coulomb from " + std::to_string(coulomb_switch);
      expect_matches_brute_force(term, system, q, target + what);
      expect_single_precision_matches_brute_force(term, system, q, target + " single," + what);
      config.precision = "mixed";
      NonbondedPairTerm mixed_term(system, config);
      expect_mixed_matches_brute_force(mixed_term, system, q, target + " mixed," + what);
    }
  }
  simd::use_target("");
  EXPECT_EQ(simd::target_name(), targets.front());
  EXPECT_THROW(simd::use_target("NO-SUCH-TARGET"), std::invalid_argument);
}

// Rows whose atom type has no LJ with any type skip the LJ terms in every kernel. The skip must
// follow the whole row of the type table: hydrogens without any LJ (SPC/E), and hydrogens whose
// only LJ is with oxygen, each against the scalar reference on every target.
TEST(PairKernels, AtomTypesWithoutLennardJonesOnEveryTarget) {
  auto [system, q] = testing::water_like_system(300, Vec3(2.5, 2.4, 2.6), 37);
  const Eigen::MatrixXd c6 = system.c6, c12 = system.c12;
  for (const bool hydrogen_with_oxygen : {false, true}) {
    system.c6 = c6, system.c12 = c12;
    system.c6(1, 1) = system.c12(1, 1) = 0;
    if (!hydrogen_with_oxygen) system.c6(0, 1) = system.c6(1, 0) = system.c12(0, 1) = system.c12(1, 0) = 0;
    const std::string table = hydrogen_with_oxygen ? "H LJ with O only" : "H without LJ";
    for (const std::string& target : simd::available_targets()) {
      simd::use_target(target);
      for (const char* modifier : {"potential-shift", "potential-switch"})
        for (const bool shared_switch : {false, true}) {
          auto config = testing::pair_config(modifier, "reaction-field", 0.0);
          if (shared_switch) {
            if (std::string(modifier) != "potential-switch") continue;
            config.coulomb_modifier = "potential-switch";
            config.coulomb_switch = config.vdw_switch;
          }
          const std::string what = target + ", " + table + ", " + modifier + (shared_switch ? ", shared switch" : "");
          NonbondedPairTerm term(system, config);
          expect_matches_brute_force(term, system, q, what);
          config.precision = "mixed";
          NonbondedPairTerm mixed_term(system, config);
          expect_mixed_matches_brute_force(mixed_term, system, q, "mixed, " + what);
        }
    }
  }
  simd::use_target("");
}

// Pairs a hair inside cut-off + skin stay listed: by the search where the list is not pruned, and
// by a pruning otherwise, also where it runs on single-precision positions (mixed precision),
// whose rounding is far larger than the hair; on every SIMD target.
TEST(NeighborList, KeepsPairsAtTheEdgeOfItsRange) {
  for (const std::string& target : simd::available_targets()) {
    simd::use_target(target);
    for (const bool pruned : {true, false}) {
      for (const char* precision : {"double", "mixed"}) {
        auto [system, q] = testing::water_like_system(500, Vec3(3.0, 3.1, 3.2), 41);
        auto config = testing::pair_config("potential-shift", "reaction-field");
        config.precision = precision;
        if (!pruned) config.neighbor_search_skin = config.neighbor_skin;
        const double range = config.cutoff + config.neighbor_skin;
        std::vector<bool> moved(q.cols(), false);
        std::vector<std::pair<int, int>> edge_pairs;
        testing::for_each_pair_distance(system, q, [&](int i, int j, double r) {
          if (std::abs(r - range) > 0.05 || moved[i] || moved[j]) return;
          const Vec3 d = system.box.minimum_image(q.col(j) - q.col(i));
          q.col(j) = q.col(i) + (range - 1e-9) / d.norm() * d;
          moved[i] = moved[j] = true;
          edge_pairs.emplace_back(i, j);
        });
        ASSERT_GT(edge_pairs.size(), 100u);
        NonbondedPairTerm term(system, config);
        ASSERT_EQ(term.skin() < term.search_skin(), pruned);
        testing::evaluate(term, q);
        int missing = 0;
        for (const auto& [i, j] : edge_pairs) missing += !term.lists_pair(i, j);
        EXPECT_EQ(missing, 0) << target << (pruned ? ", pruned, " : ", searched, ") << precision << ": of "
                              << edge_pairs.size() << " pairs at the edge";
      }
    }
  }
  simd::use_target("");
}

// Pairs that were just inside cut-off + skin at the build are pulled together by almost skin/2
// per atom, so they end up inside the cut-off without a rebuild: they must still be counted.
TEST(NeighborList, CatchesPairsClosingInFromTheEdgeOfTheBuffer) {
  auto [system, q] = testing::water_like_system(500, Vec3(3.0, 3.0, 3.0), 23);
  for (const char* coulomb : {"reaction-field", "none"}) {
    const auto config = testing::pair_config("potential-shift", coulomb);
    NonbondedPairTerm term(system, config);
    testing::evaluate(term, q);
    const double rc = config.cutoff, skin = config.neighbor_skin;
    std::vector<bool> moved(q.cols(), false);
    Coords target = q;
    int pulled = 0;
    testing::for_each_pair_distance(system, q, [&](int i, int j, double r) {
      if (r < rc + 0.98 * skin || r >= rc + skin || moved[i] || moved[j]) return;
      const Vec3 d = system.box.minimum_image(q.col(i) - q.col(j)) / r;
      target.col(i) -= 0.4999 * skin * d;
      target.col(j) += 0.4999 * skin * d;
      moved[i] = moved[j] = true;
      ++pulled;
    });
    ASSERT_GT(pulled, 20);
    int now_inside = 0;
    testing::for_each_pair_distance(system, target, [&](int i, int j, double r) {
      if (moved[i] && moved[j] && r < rc) ++now_inside;
    });
    ASSERT_GT(now_inside, 20);
    expect_matches_brute_force(term, system, target, std::string("pulled pairs, ") + coulomb);
    EXPECT_EQ(testing::work(term).neighbor_rebuilds, 1);
  }
}

// The same at the edge of the searched list: pairs just inside cut-off + search skin at the search
// close in by almost (search skin − skin) (a pruning, no search), then by almost the skin (no
// pruning), ending inside the cut-off: the pruning must have kept them.
TEST(NeighborList, CatchesPairsClosingInFromTheEdgeOfTheSearchedList) {
  auto [system, q] = testing::water_like_system(500, Vec3(3.2, 3.2, 3.2), 29);
  auto config = testing::pair_config("potential-shift", "reaction-field");
  config.neighbor_search_skin = 0.5;
  NonbondedPairTerm term(system, config);
  testing::evaluate(term, q);
  const double rc = config.cutoff, skin = config.neighbor_skin, search_skin = *config.neighbor_search_skin;
  std::vector<bool> moved(q.cols(), false);
  std::vector<std::pair<int, Vec3>> pulls;  // atom, unit direction
  testing::for_each_pair_distance(system, q, [&](int i, int j, double r) {
    if (r < rc + 0.98 * search_skin || r >= rc + 0.99 * search_skin || moved[i] || moved[j]) return;
    const Vec3 d = system.box.minimum_image(q.col(i) - q.col(j)) / r;
    pulls.push_back({i, -d});
    pulls.push_back({j, d});
    moved[i] = moved[j] = true;
  });
  ASSERT_GT(pulls.size(), 40u);
  for (const double distance : {0.4999 * (search_skin - skin), 0.4999 * skin}) {
    for (const auto& [atom, direction] : pulls) q.col(atom) += distance * direction;
    expect_matches_brute_force(term, system, q, "pulled by " + std::to_string(distance));
  }
  int now_inside = 0;
  testing::for_each_pair_distance(system, q, [&](int i, int j, double r) {
    if (moved[i] && moved[j] && r < rc) ++now_inside;
  });
  EXPECT_GT(now_inside, 20);
  EXPECT_EQ(testing::work(term).neighbor_rebuilds, 1);
  EXPECT_EQ(testing::work(term).neighbor_prunes, 2);
}

// A variational step (start_step with a continuous force at the cut-off) visits a step list, cut
// to cut-off + a step skin around the step's start: the same results bit for bit as the regular
// list (the dropped pairs add exact zeros), over fewer entries; an evaluation beyond half the step
// skin prunes it again there. Once single-precision positions are kept, the step list is cut on
// them: the same results.
TEST(NeighborList, StepListGivesTheRegularResultsBitForBit) {
  for (const bool single_cut : {false, true}) {
    auto [system, q0] = testing::water_like_system(500, Vec3(3.0, 2.9, 3.1), 41);
    const auto config = testing::pair_config("potential-switch", "reaction-field", 0.0);
    NonbondedPairTerm stepped(system, config), plain(system, config);
    if (single_cut) {  // from now on the term keeps single-precision positions
      TermEvaluation single;
      single.single_precision = true;
      testing::evaluate(stepped, q0, single);
    }
    std::mt19937_64 rng(12);
    const Coords u = random_vectors(static_cast<int>(q0.cols()), rng, 1.0);
    std::unique_ptr<TermStepState> step_state;
    TermEvaluation in_step;
    auto expect_same = [&](const Coords& q, const std::string& what) {
      const auto a = testing::evaluate(stepped, q, in_step), b = testing::evaluate(plain, q);
      EXPECT_EQ(a.energies, b.energies) << what;
      EXPECT_EQ((a.f - b.f).cwiseAbs().maxCoeff(), 0.0) << what;
      const Coords hu = testing::hessian_vector(stepped, q, u, in_step);
      EXPECT_EQ((hu - testing::hessian_vector(plain, q, u)).cwiseAbs().maxCoeff(), 0.0) << what;
    };
    expect_same(q0, "start");
    const std::size_t regular_entries = stepped.visited_entries();
    Coords q = q0;
    // Evaluations reaching 0.006 nm from each step's start; the first step's skin is half the pruned one's.
    for (int step = 0; step < 3; ++step) {
      const Coords start = q;
      const long prunes = testing::work(stepped).neighbor_prunes;
      stepped.start_step(start, step_state);
      in_step.step = step_state.get();
      EXPECT_LT(stepped.visited_entries(step_state.get()), regular_entries) << "step " << step;
      for (double reach : {0.002, 0.006, 0.004}) {
        q = start + random_vectors(static_cast<int>(q.cols()), rng, reach);
        expect_same(q, "step " + std::to_string(step) + ", reach " + std::to_string(reach));
        expect_matches_brute_force(stepped, system, q, "step list, step " + std::to_string(step), nullptr,
                                   step_state.get());
      }
      EXPECT_EQ(testing::work(stepped).neighbor_prunes, prunes + 1) << "step " << step << ": one step list, no regular pruning";
      in_step.step = nullptr;
      EXPECT_EQ(stepped.visited_entries(), plain.visited_entries()) << "outside the step";
    }
    // The last step reached 0.006 nm: this one's skin is 2.6 x 0.006 nm, and an evaluation 0.012 nm
    // away prunes again (still within the pruned list's half skin: no regular pruning).
    const Coords start = q;
    const long prunes = testing::work(stepped).neighbor_prunes;
    stepped.start_step(start, step_state);
    in_step.step = step_state.get();
    q = start + random_vectors(static_cast<int>(q.cols()), rng, 0.012);
    expect_same(q, "beyond the step skin");
    expect_matches_brute_force(stepped, system, q, "beyond the step skin", nullptr, step_state.get());
    EXPECT_EQ(testing::work(stepped).neighbor_prunes, prunes + 2);
    EXPECT_EQ(testing::work(stepped).neighbor_rebuilds, 1);
  }
}

// Where the force jumps at the cut-off, start_step(q) freezes the pairs inside it at q: at moved
// positions the kernels sum exactly those pairs, each continued past the cut-off.
TEST(NeighborList, FixedPairSetMatchesBruteForce) {
  auto [system, q] = testing::water_like_system(500, Vec3(3.0, 2.9, 3.1), 43);
  for (const char* modifier : {"potential-shift", "none"}) {
    NonbondedPairTerm term(system, testing::pair_config(modifier, "reaction-field", 78.0));
    std::mt19937_64 rng(13);
    const Coords moved = q + random_vectors(static_cast<int>(q.cols()), rng, 0.02);
    int crossed = 0;
    const double rc = term.form<LjConstants>().cutoff;
    testing::for_each_pair_distance(system, q, [&](int i, int j, double r) {
      crossed += (r < rc) != ((system.box.minimum_image(moved.col(i) - moved.col(j)).norm()) < rc);
    });
    ASSERT_GT(crossed, 10) << modifier;
    testing::evaluate(term, q);
    std::unique_ptr<TermStepState> step;
    term.start_step(q, step);
    expect_matches_brute_force(term, system, moved, std::string(modifier) + ", pairs fixed at q", &q, step.get());
    expect_matches_brute_force(term, system, moved, std::string(modifier) + ", outside the step");
  }
}

TEST(NeighborList, UnwrappedCoordinatesGiveTheSameResult) {
  auto [system, q] = testing::water_like_system(300, Vec3(2.7, 2.5, 2.6), 31);
  const auto config = testing::pair_config("potential-switch", "reaction-field", 78.0);
  NonbondedPairTerm wrapped_term(system, config), unwrapped_term(system, config);
  // Whole molecules and single atoms several boxes away, as long runs produce them.
  std::mt19937_64 rng(8);
  std::uniform_int_distribution<int> image(-3, 3);
  Coords unwrapped = q;
  for (int i = 0; i < q.cols(); ++i)
    for (int k = 0; k < 3; ++k) unwrapped(k, i) += image(rng) * system.box.length[k];
  const auto a = testing::evaluate(wrapped_term, q);
  const auto b = testing::evaluate(unwrapped_term, unwrapped);
  const Reference ref = brute_force(wrapped_term, system, q, q);
  EXPECT_NEAR(a.energies[0], b.energies[0], 1e-12 * ref.lj_scale);
  EXPECT_NEAR(a.energies[1], b.energies[1], 1e-12 * ref.coulomb_scale);
  EXPECT_LT(relative_difference(b.f, a.f), 1e-12);
  expect_matches_brute_force(unwrapped_term, system, unwrapped, "unwrapped");
  // Moving on from unwrapped positions keeps working across searches (beyond (0.35 − 0.1)/2 nm:
  // the automatic search skin of this box is 0.35 nm).
  ASSERT_NEAR(unwrapped_term.search_skin(), 0.35, 1e-12);
  Coords moved = unwrapped + random_vectors(static_cast<int>(q.cols()), rng, 0.13);
  expect_matches_brute_force(unwrapped_term, system, moved, "unwrapped, moved");
  EXPECT_EQ(testing::work(unwrapped_term).neighbor_rebuilds, 2);
}

TEST(NeighborList, SmallPartlyPeriodicAndNonPeriodicBoxes) {
  struct Case {
    const char* name;
    Vec3 box, extent;
    int molecules;
  };
  const Case cases[] = {
      {"box just above twice the cut-off", Vec3(1.81, 1.85, 1.9), Vec3::Zero(), 40},
      {"thin slab, z not periodic", Vec3(2.2, 2.3, 0.0), Vec3(0, 0, 1.2), 60},
      {"non-periodic cluster", Vec3::Zero(), Vec3(2.5, 2.0, 2.2), 120},
      {"single molecule", Vec3::Zero(), Vec3(0.1, 0.1, 0.1), 1},
      {"elongated box", Vec3(6.0, 1.9, 1.9), Vec3::Zero(), 150},
  };
  for (const Case& c : cases)
    for (const char* modifier : kModifiers) {
      auto [system, q] = testing::water_like_system(c.molecules, c.box, 41, c.extent);
      NonbondedPairTerm term(system, testing::pair_config(modifier, "reaction-field", 0.0));
      const std::string what = std::string(c.name) + ", " + modifier;
      expect_matches_brute_force(term, system, q, what);
      std::mt19937_64 rng(3);
      expect_matches_brute_force(term, system, q + random_vectors(static_cast<int>(q.cols()), rng, 0.049),
                                 what + " moved");
      expect_matches_brute_force(term, system, q + random_vectors(static_cast<int>(q.cols()), rng, 0.2), what + " far");
    }
}

// Structure: every atom pair image within cut-off + skin at the build is listed exactly once,
// excluded pairs are absent from the cluster pairs and present in excluded_pairs().
// The search tests distances in single precision, widened by their rounding: every pair in range
// listed, none far beyond it, and each entry's `nearest` a lower bound, close to the true one; on
// every SIMD target.
// The stored nearest distance never exceeds the distance (a pruning skips by it), loses at most one
// unit below 2 nm, and holds everything from 2 nm on, and anything not a positive number, safely low.
TEST(NeighborList, NearestDistanceCodeIsALowerBound) {
  const float unit = NeighborList::kNearestUnit;
  for (float d = 0; d < 2.1f; d = std::nextafter(d + 0.000731f, 3.0f)) {
    const float decoded = NeighborList::encode_nearest(d) * unit;
    ASSERT_LE(decoded, d) << d;
    if (d < 2.0f - unit) {
      ASSERT_GT(decoded, d - unit) << d;
    }
  }
  EXPECT_EQ(NeighborList::encode_nearest(2.0f - unit), 65535);
  EXPECT_EQ(NeighborList::encode_nearest(1e30f), 65535);
  EXPECT_EQ(NeighborList::encode_nearest(std::numeric_limits<float>::infinity()), 65535);
  EXPECT_EQ(NeighborList::encode_nearest(-1e-5f), 0);
  EXPECT_EQ(NeighborList::encode_nearest(std::numeric_limits<float>::quiet_NaN()), 0);
}

TEST(NeighborList, ListsEveryPairInRangeExactlyOnce) {
  const auto targets = simd::available_targets();
  const Vec3 boxes[] = {Vec3(2.4, 2.5, 2.6), Vec3(1.85, 1.85, 1.85), Vec3(0.0, 0.0, 0.0)};
  for (std::size_t run = 0; run < targets.size() * std::size(boxes); ++run) {
    const std::string& target = targets[run / std::size(boxes)];
    const Vec3& box = boxes[run % std::size(boxes)];
    SCOPED_TRACE(target + ", box " + std::to_string(box[0]));
    simd::use_target(target);
    auto [system, q] = testing::water_like_system(150, box, 51, Vec3(2.0, 2.0, 2.0));
    NeighborList list(system.box, 0.9, 0.1, system.exclusions);
    list.build(q);
    const double range = 1.0, rounding = 1e-4;
    std::vector<double> x(list.n_slots()), y(list.n_slots()), z(list.n_slots());
    list.pack_positions(q, x.data(), y.data(), z.data());
    // (i, j, image of j relative to i) with i < j → times listed
    std::map<std::tuple<int, int, int, int, int>, int> listed;
    for (int h = 0; h < list.n_halves(); ++h)
      for (int e = list.half_start()[h]; e < list.half_start()[h + 1]; ++e) {
        const auto& entry = list.entries()[e];
        double nearest = INFINITY;
        for (int ii = 0; ii < NeighborList::kHalfSize; ++ii)
          for (int jj = 0; jj < NeighborList::kClusterSize; ++jj) {
            const int sa = h * NeighborList::kHalfSize + ii, sb = entry.j_cluster() * NeighborList::kClusterSize + jj;
            if (list.slot_atom()[sa] >= 0 && list.slot_atom()[sb] >= 0)
              nearest = std::min(nearest, (Vec3(x[sa] - x[sb], y[sa] - y[sb], z[sa] - z[sb]) -
                                           list.shift_vectors()[entry.shift()]).norm());
          }
        const double listed_nearest = list.nearest()[e] * NeighborList::kNearestUnit;
        ASSERT_LE(listed_nearest, nearest);
        ASSERT_GT(listed_nearest, nearest - rounding);
        for (int ii = 0; ii < NeighborList::kHalfSize; ++ii)
          for (int jj = 0; jj < NeighborList::kClusterSize; ++jj) {
            if (!((entry.mask >> (ii * NeighborList::kClusterSize + jj)) & 1u)) continue;
            const int sa = h * NeighborList::kHalfSize + ii, sb = entry.j_cluster() * NeighborList::kClusterSize + jj;
            const int a = list.slot_atom()[sa], b = list.slot_atom()[sb];
            ASSERT_GE(a, 0);
            ASSERT_GE(b, 0);
            ASSERT_NE(a, b);
            const Vec3 d = Vec3(x[sa] - x[sb], y[sa] - y[sb], z[sa] - z[sb]) - list.shift_vectors()[entry.shift()];
            ASSERT_LT(d.norm(), range + rounding);
            int n[3];
            for (int k = 0; k < 3; ++k)
              n[k] = box[k] > 0 ? static_cast<int>(std::lround((q(k, a) - q(k, b) - d[k]) / box[k])) : 0;
            if (a < b)
              ++listed[{a, b, n[0], n[1], n[2]}];
            else
              ++listed[{b, a, -n[0], -n[1], -n[2]}];
          }
      }
    for (const auto& [key, count] : listed) ASSERT_EQ(count, 1) << "pair listed twice";
    int in_range = 0;
    const int m[3] = {box[0] > 0, box[1] > 0, box[2] > 0};
    for (int i = 0; i < q.cols(); ++i)
      for (int j = i + 1; j < q.cols(); ++j)
        for (int nx = -m[0]; nx <= m[0]; ++nx)
          for (int ny = -m[1]; ny <= m[1]; ++ny)
            for (int nz = -m[2]; nz <= m[2]; ++nz) {
              const Vec3 d = q.col(i) - q.col(j) - Vec3(nx * box[0], ny * box[1], nz * box[2]);
              const bool is_listed = listed.count({i, j, nx, ny, nz}) > 0;
              if (system.molecule[i] == system.molecule[j]) {
                EXPECT_FALSE(is_listed) << "excluded pair " << i << "," << j << " listed";
              } else if (d.norm() < range) {
                ++in_range;
                EXPECT_TRUE(is_listed) << "pair " << i << "," << j << " at " << d.norm() << " missing";
              }
            }
    EXPECT_GT(in_range, 1000);
    int excluded_pairs = 0;
    for (const auto& e : system.exclusions) excluded_pairs += static_cast<int>(e.size());
    EXPECT_EQ(static_cast<int>(list.excluded_pairs().size()), excluded_pairs / 2);
  }
  simd::use_target("");
}

// A list of more entries than four search chunks hold (two a thread at two threads): every
// half's entries, read in place, are entries() in half order, and the listed pairs are exactly the
// pairs in range (up to the search's rounding).
TEST(NeighborList, LargeListsKeepEveryHalfInPlace) {
  const double cutoff = 0.9, skin = 0.7, range = cutoff + skin, rounding = 1e-4;
  auto [system, q] = testing::water_like_system(1500, Vec3(3.9, 3.8, 4.0), 78);
  NeighborList list(system.box, cutoff, skin, system.exclusions);
  list.build(q);
  ASSERT_GT(list.entries().size(), 4u << 15) << "too few entries for two chunks a thread";
  std::vector<const NeighborList::Entry*> entries;
  std::vector<const NeighborList::NearestDistance*> nearest;
  list.point_to_halves(entries, nearest);
  long listed = 0;
  for (int h = 0; h < list.n_halves(); ++h)
    for (int e = list.half_start()[h], k = 0; e < list.half_start()[h + 1]; ++e, ++k) {
      ASSERT_EQ(entries[h][k].j_cluster(), list.entries()[e].j_cluster());
      ASSERT_EQ(entries[h][k].shift(), list.entries()[e].shift());
      ASSERT_EQ(entries[h][k].mask, list.entries()[e].mask);
      ASSERT_EQ(nearest[h][k], list.nearest()[e]);
      listed += std::popcount(entries[h][k].mask);
    }
  std::set<std::pair<int, int>> excluded;
  for (int a = 0; a < q.cols(); ++a)
    for (int b : system.exclusions[a]) excluded.insert({a, b});
  long surely_in = 0, maybe_in = 0;
  for (int a = 0; a < q.cols(); ++a)
    for (int b = a + 1; b < q.cols(); ++b) {
      if (excluded.count({a, b})) continue;
      const double d = system.box.minimum_image(q.col(a) - q.col(b)).norm();
      surely_in += d < range - rounding;
      maybe_in += d < range + rounding;
    }
  EXPECT_GE(listed, surely_in);
  EXPECT_LE(listed, maybe_in);
}

// Each thread's share of the slots, listed by atom (padding last), and of the atoms, listed by
// slot, hold exactly that share; packing with them inside a team gives the serial pack's bits.
TEST(NeighborList, ThreadSharesListedInTheOtherOrder) {
  const int saved_threads = omp_get_max_threads(), nt = 3;
  omp_set_num_threads(nt);
  auto [system, q] = testing::water_like_system(150, Vec3(2.4, 2.5, 2.6), 52);
  NeighborList list(system.box, 0.9, 0.1, system.exclusions);
  list.build(q);
  omp_set_num_threads(saved_threads);
  const int* slots = list.share_slots_by_atom(nt);
  const int* atoms = list.share_atoms_by_slot(nt);
  ASSERT_NE(slots, nullptr);
  ASSERT_NE(atoms, nullptr);
  EXPECT_EQ(list.share_slots_by_atom(nt + 1), nullptr);
  EXPECT_EQ(list.share_atoms_by_slot(nt - 1), nullptr);
  const auto& slot_atom = list.slot_atom();
  const auto& atom_slot = list.atom_slot();
  for (int t = 0; t < nt; ++t) {
    SCOPED_TRACE("thread " + std::to_string(t));
    const int s0 = share_begin(list.n_slots(), t, nt), s1 = share_begin(list.n_slots(), t + 1, nt);
    std::vector<int> share(slots + s0, slots + s1);
    // By atom, and the padding (atom −1 here) after the atoms.
    EXPECT_TRUE(std::is_sorted(share.begin(), share.end(), [&](int a, int b) {
      const unsigned ka = static_cast<unsigned>(slot_atom[a]), kb = static_cast<unsigned>(slot_atom[b]);
      return ka < kb;
    }));
    std::sort(share.begin(), share.end());
    for (int i = s0; i < s1; ++i) ASSERT_EQ(share[i - s0], i);
    const int a0 = share_begin(list.n_atoms(), t, nt), a1 = share_begin(list.n_atoms(), t + 1, nt);
    std::vector<int> mine(atoms + a0, atoms + a1);
    EXPECT_TRUE(std::is_sorted(mine.begin(), mine.end(), [&](int a, int b) { return atom_slot[a] < atom_slot[b]; }));
    std::sort(mine.begin(), mine.end());
    for (int i = a0; i < a1; ++i) ASSERT_EQ(mine[i - a0], i);
  }
  const int n = list.n_slots();
  std::vector<double> serial(3 * n, -1), team(3 * n, -1);
  list.pack_positions(q, serial.data(), serial.data() + n, serial.data() + 2 * n);
#pragma omp parallel num_threads(nt)
  list.pack_positions(q, team.data(), team.data() + n, team.data() + 2 * n);
  EXPECT_EQ(serial, team);
}

TEST(NeighborList, RejectsBoxesShorterThanTwiceTheCutoff) {
  Box box;
  box.length = Vec3(1.7, 3.0, 3.0);
  EXPECT_THROW(NeighborList(box, 0.9, 0.1, {}), InputError);
}

}  // namespace
}  // namespace vimd
