#include "forcefields/nonbonded/pair_lists.hpp"

#include <omp.h>

#include <chrono>
#include <cmath>
#include <numeric>
#include <stdexcept>

#include "forcefields/nonbonded/nonbonded_kernels.hpp"

namespace vimd {

namespace {

double max_abs_coordinate(const Coords& q) {
  double m = 0;  // a plain loop: Eigen's AVX-512 reduction trips a GCC 12 false-positive warning
  for (Eigen::Index k = 0; k < q.size(); ++k) m = std::max(m, std::abs(q.data()[k]));
  return m;
}

// The step list's skin: twice the largest displacement from its start that the last step's
// evaluations reached, times a margin for this step reaching further (an evaluation beyond half
// the skin costs another pruning). Never below kMinStepSkin, far above the rounding of
// single-precision distances.
constexpr double kStepReachMargin = 1.3;
constexpr double kMinStepSkin = 0.005;  // nm

// Lists with fewer entries are narrowed on one thread: starting a team would cost more. The
// displacements before a pruning go parallel as per-atom loops do: run on one thread, they kept
// the others waiting.
constexpr std::size_t kParallelEntries = 2048;

double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace

PairLists::PairLists(const Box& box, double cutoff, double search_skin, double skin,
                     std::vector<std::vector<int>> exclusions, std::vector<char> leading)
    : skin_(skin), list_(box, cutoff, search_skin, std::move(exclusions), std::move(leading)) {}

void PairLists::search(const Coords& q, double allowed) {
  const long builds = list_.builds();
  list_.update(q, allowed);
  if (list_.builds() != builds) searched_id_ = ++changes_;
}

void PairLists::keep_regular(const Coords& q, double allowed, bool single) {
  if (!pruning()) {
    search(q, allowed);
  } else if (prunes_ == 0 || max_displacement(q, pruned_at_) > allowed) {
    search(q, 0.5 * (list_.skin() - skin_));
    prune(q, single);
  }
}

void PairLists::prune(const Coords& q, bool single) {
  const auto start = std::chrono::steady_clock::now();
  const double range = list_.cutoff() + skin_;
  // Since the search no pair of half h and cluster c came closer by more than the largest
  // displacements among their atoms, D_h + D_c: an entry whose atoms were all that much beyond the
  // pruned range then cannot have a pair inside it now. Water moves unevenly: most entries' bound
  // is well below twice the largest displacement of all.
  const int n_halves = list_.n_halves();
  half_skip_.resize(n_halves);
  cluster_moved_.resize(list_.n_clusters());
  const Coords& searched_at = list_.built_at();
  const std::vector<int>& slot_atom = list_.slot_atom();
  constexpr int kHalf = NeighborList::kHalfSize;
  // Rounded up to floats with room for the rounding of their float sum in the kernel.
  const auto rounded_up = [](double x) {
    const double widened = x * (1 + 0x1p-22);
    float f = static_cast<float>(widened);
    return f < widened ? std::nextafter(f, INFINITY) : f;
  };
#pragma omp parallel for schedule(static) if (list_.n_slots() >= kParallelMinAtoms)
  for (int c = 0; c < list_.n_clusters(); ++c) {
    double half_moved2[2] = {0, 0};
    for (int k = 0; k < NeighborList::kClusterSize; ++k) {
      const int a = slot_atom[c * NeighborList::kClusterSize + k];
      if (a < 0) continue;
      double& moved2 = half_moved2[k / kHalf];
      moved2 = std::max(moved2, (q.col(a) - searched_at.col(a)).squaredNorm());
    }
    for (int i = 0; i < 2; ++i) half_skip_[2 * c + i] = rounded_up(range + std::sqrt(half_moved2[i]));
    cluster_moved_[c] = rounded_up(std::sqrt(std::max(half_moved2[0], half_moved2[1])));
  }
  narrow(searched_halves(), q, range, single, pruned_);
  pruned_at_ = q;
  ++prunes_;
  prune_seconds_ += seconds_since(start);
}

void PairLists::narrow(const PairListView& from, const Coords& q, double range, bool single, PairListEntries& to) {
  const int n_slots = list_.n_slots();
  const std::size_t n_entries = from.size();
  // Single-precision distances are compared with a range widened by a bound on their rounding
  // (coordinates and shifts below `magnitude`; a few roundings of each difference), so that every
  // pair truly within the range is kept.
  const double float_range =
      range + single_precision_rounding(max_abs_coordinate(q) + 2 * list_.box().length.maxCoeff() + range);
  if (single) {
    for (auto* v : {&x_single_, &y_single_, &z_single_}) v->resize(n_slots);
  } else {
    for (auto* v : {&x_, &y_, &z_}) v->resize(n_slots);
  }
  if (!from.half_nearest.empty() && (half_skip_.size() != from.half_start.size() - 1 ||
                                     cluster_moved_.size() != static_cast<std::size_t>(list_.n_clusters())))
    throw std::logic_error("PairLists::narrow: skipping by distance needs each half's and cluster's displacement");
  const NeighborList::Entry* const* half_entries = from.half_entries.empty() ? nullptr : from.half_entries.data();
  const NeighborList::NearestDistance* const* half_nearest =
      from.half_nearest.empty() ? nullptr : from.half_nearest.data();
  PairPositionsOf<double> view{x_.data(),           y_.data(),     z_.data(),         from.entries.data(),
                               from.half_start.data(), list_.shift_vectors().data(), range * range,
                               half_entries,          half_nearest,  half_skip_.data(), cluster_moved_.data()};
  PairPositionsOf<float> float_view{x_single_.data(),       y_single_.data(),     z_single_.data(),
                                    from.entries.data(),    from.half_start.data(), list_.shift_vectors().data(),
                                    float_range * float_range, half_entries,     half_nearest,
                                    half_skip_.data(),      cluster_moved_.data()};
  const NarrowKernel kernel = simd::narrow_kernel();
  const SingleNarrowKernel float_kernel = simd::single_narrow_kernel();
  const int n_halves = list_.n_halves();
  to.half_start.assign(n_halves + 1, 0);
  const bool parallel = n_entries >= kParallelEntries;
  to.parts.resize(std::max<std::size_t>(to.parts.size(), pair_loop_segments(parallel ? omp_get_max_threads() : 1)));
  to.part_begin.assign(to.parts.size(), 0);
  to.part_end.assign(to.parts.size(), 0);
  std::atomic<int> next_tail{0};
  // The pair loop's segments (a slower thread takes fewer tails): each narrows its chunks of halves
  // into its own part, and counts what each half keeps.
#pragma omp parallel if (parallel)
  {
    if (single)
      list_.pack_positions(q, x_single_.data(), y_single_.data(), z_single_.data());
    else
      list_.pack_positions(q, x_.data(), y_.data(), z_.data());
    const int t = omp_get_thread_num(), nt = omp_get_num_threads();
    take_segments(t, nt, next_tail, [&](int s) {
      std::vector<NeighborList::Entry>& part = to.parts[s];
      std::size_t kept = 0;
      bool first_chunk = true;
      for_segment_chunks(from.half_start, s, nt, [&](int h0, int h1) {
        if (first_chunk) to.part_begin[s] = h0, first_chunk = false;
        to.part_end[s] = h1;
        const std::size_t room = kept + (from.half_start[h1] - from.half_start[h0]);
        if (room > part.size()) {
          if (room > part.capacity()) part.reserve(room + room / 8);  // not doubling: the list is large
          part.resize(room);
        }
        int* kept_of_half = to.half_start.data() + h0 + 1;
        kept += single ? float_kernel(float_view, h0, h1, part.data() + kept, kept_of_half)
                       : kernel(view, h0, h1, part.data() + kept, kept_of_half);
      });
    });
  }
  std::partial_sum(to.half_start.begin(), to.half_start.end(), to.half_start.begin());
  to.point_to_parts();
  to.id = ++changes_;
}

PairListEntries& PairListEntries::operator=(const PairListEntries& other) {
  parts = other.parts;
  part_begin = other.part_begin;
  part_end = other.part_end;
  half_start = other.half_start;
  id = other.id;
  point_to_parts();
  return *this;
}

void PairListEntries::point_to_parts() {
  half_entries.resize(half_start.empty() ? 0 : half_start.size() - 1);
  for (std::size_t t = 0; t < parts.size(); ++t)
    for (int h = part_begin[t]; h < part_end[t]; ++h)
      half_entries[h] = parts[t].data() + (half_start[h] - half_start[part_begin[t]]);
}

double PairLists::step_skin_after(double reach) const {
  if (reach < 0) return 0.5 * skin_;  // no step yet
  return std::clamp(2 * kStepReachMargin * reach, kMinStepSkin, skin_);
}

void PairLists::start_step(StepList& step, const Coords& q, bool fixed, bool single) {
  if (step.build >= 0) step.last_reach = step.reach;
  step.reach = 0;
  prune_step(step, q, fixed ? 0 : step_skin_after(step.last_reach), single);
}

void PairLists::keep_step(StepList& step, const Coords& q, bool single) {
  if (step.build != list_.builds()) {
    // A search since the step began renumbered the slots its entries refer to.
    if (step.skin == 0)
      throw std::logic_error("PairLists: a fixed pair set outlived the search it was taken from");
    prune_step(step, q, step.skin, single);
    return;
  }
  if (step.skin == 0) return;  // a fixed pair set needs no new pairs
  const double moved = max_displacement(q, step.at);
  step.reach = std::max(step.reach, moved);
  if (moved > 0.5 * step.skin) prune_step(step, q, step_skin_after(moved), single);
}

void PairLists::prune_step(StepList& step, const Coords& q, double skin, bool single) {
  // The regular list must then hold every pair within cut-off + skin at q.
  keep_regular(q, 0.5 * (skin_ - skin), single);
  const auto start = std::chrono::steady_clock::now();
  // The fixed pair set (skin 0) is exactly the pairs inside the cut-off at q: double-precision
  // distances. A buffered step list may be cut on the cheaper single-precision ones.
  narrow(regular(), q, list_.cutoff() + skin, skin > 0 && single, step.list);
  step.at = q;
  step.skin = skin;
  step.build = list_.builds();
  ++step_prunes_;
  prune_seconds_ += seconds_since(start);
}

void PairLists::add_work(WorkCounters& counters) const {
  counters.neighbor_rebuilds += list_.builds();
  counters.neighbor_prunes += prunes_ + step_prunes_;
  counters.neighbor_build_seconds += list_.build_seconds() + prune_seconds_;
}

void PairLists::save(Carried& out) const {
  if (list_.builds() > 0) out.put("neighbor_list_built_at", list_.built_at());
  if (prunes_ > 0) out.put("neighbor_list_pruned_at", pruned_at_);
}

void PairLists::restore(const Carried& in, bool single) {
  if (!in.has("neighbor_list_built_at")) return;
  const Coords built_at = in.coords("neighbor_list_built_at");
  list_.build(built_at);  // the same positions give the same list, hence the same summation order
  searched_id_ = ++changes_;
  if (in.has("neighbor_list_pruned_at")) {
    const Coords pruned_at = in.coords("neighbor_list_pruned_at");
    if (pruned_at.cols() != built_at.cols()) throw std::invalid_argument("PairLists::restore: wrong number of atoms");
    prune(pruned_at, single);
  }
}

}  // namespace vimd
