#pragma once
// The pair lists the nonbonded pair loop visits.
//
// Two lists, as GROMACS's dynamic pruning: the searched list (NeighborList) holds every cluster
// pair within cut-off + search skin; the loop runs over a pruned copy, its pairs within cut-off +
// skin, redone by one cheap SIMD pass whenever an atom has moved skin/2 since the last pruning. The
// search is redone only when an atom has moved (search skin − skin)/2 since it ran, so the pruned
// range, hence every pair inside the cut-off, is always covered: exact, like a single list.
//
// A third, for one variational step (StepList): its evaluations stay within ~h·|v|max of the
// step's start q̂, so a list pruned at q̂ to cut-off + step skin, a few hundredths of a nm, serves
// them all, and the single-precision kernels waste fewer lanes on pairs beyond the cut-off. The
// step skin is twice the largest displacement from q̂ of the last step's evaluations, with a
// margin; an evaluation beyond half of it prunes again there, so the list stays exact. Where the
// force jumps at the cut-off, the step list is the fixed pair set (skin 0). The dropped pairs would
// have added exact zeros: results are bitwise those of the wider list.
#include <algorithm>
#include <atomic>
#include <span>
#include <vector>

#include "engine/force_field.hpp"
#include "forcefields/nonbonded/neighbor_list.hpp"

namespace vimd {

// The pair loop's unit of work: i-halves in chunks of kHalfChunk. The list is cut into segments
// (below) by entries at chunk boundaries (early halves, paired with all later clusters, hold more
// entries than late ones), each a contiguous run of chunks, on its own part of the box; chunks of a
// few halves keep the segments within a fraction of a per cent of their shares. The cut depends
// only on the list and the thread count, as the summation order must.
constexpr int kHalfChunk = 4;

inline int half_chunks(int n_halves) { return (n_halves + kHalfChunk - 1) / kHalfChunk; }

// The chunk boundary nearest to entry `target` of the list; half_start: its entries by half.
inline int nearest_chunk_boundary(std::span<const int> half_start, long target) {
  const int n_halves = static_cast<int>(half_start.size()) - 1;
  auto chunk_start = [&](int c) { return half_start[std::min(n_halves, c * kHalfChunk)]; };
  int lo = 0, hi = half_chunks(n_halves);
  while (lo < hi) {
    const int mid = (lo + hi) / 2;
    if (chunk_start(mid) < target)
      lo = mid + 1;
    else
      hi = mid;
  }
  return lo > 0 && target - chunk_start(lo - 1) < chunk_start(lo) - target ? lo - 1 : lo;
}

// The pair loop's segments with nt threads: each thread's home run of chunks first, together all
// but kTailSegments / kTailDenominator of the entries; then kTailSegments runs of
// 1 / kTailDenominator each at the list's end, which the threads take in turn as they finish, so
// that a thread on a slower core (a busy sibling, a neighbour on a shared host) does not keep the
// others waiting. A segment's sums go to a buffer of its own and the buffers are summed in segment
// order, so the results depend on the list and nt, not on which thread ran which tail. One thread:
// one segment, the whole list.
constexpr int kTailSegments = 2;
constexpr int kTailDenominator = 10;

inline int pair_loop_segments(int nt) { return nt > 1 ? nt + kTailSegments : 1; }

// Segment s's first chunk boundary (s = pair_loop_segments(nt): the end of the list).
inline int segment_boundary(std::span<const int> half_start, int s, int nt) {
  const int n_halves = static_cast<int>(half_start.size()) - 1;
  const int segments = pair_loop_segments(nt);
  if (s == 0) return 0;
  if (s == segments) return half_chunks(n_halves);
  const long total = half_start[n_halves];
  constexpr long kHome = kTailDenominator - kTailSegments;
  const long target = s <= nt ? total * kHome * s / (static_cast<long>(kTailDenominator) * nt)
                               : total * (kHome + s - nt) / kTailDenominator;
  return nearest_chunk_boundary(half_start, target);
}

// Segment s's first half.
inline int segment_first_half(std::span<const int> half_start, int s, int nt) {
  return std::min(static_cast<int>(half_start.size()) - 1, segment_boundary(half_start, s, nt) * kHalfChunk);
}

// f(s) for the segments thread t of nt runs: its home segment t, then tails as next_tail (shared by
// the threads, from 0) hands them out.
template <class F>
void take_segments(int t, int nt, std::atomic<int>& next_tail, F&& f) {
  f(t);
  for (int s; (s = nt + next_tail.fetch_add(1, std::memory_order_relaxed)) < pair_loop_segments(nt);) f(s);
}

// f(h0, h1) for the chunks of segment s of pair_loop_segments(nt).
template <class F>
void for_segment_chunks(std::span<const int> half_start, int s, int nt, F&& f) {
  const int n_halves = static_cast<int>(half_start.size()) - 1, end = segment_boundary(half_start, s + 1, nt);
  for (int c = segment_boundary(half_start, s, nt); c < end; ++c)
    f(c * kHalfChunk, std::min(n_halves, (c + 1) * kHalfChunk));
}

// Cluster-pair entries by i-half: entries[half_start[h] .. half_start[h + 1]), and an id that
// changes whenever the entries do (masks refer to entry numbers).
struct PairListView {
  std::span<const NeighborList::Entry> entries;
  std::span<const int> half_start;
  long id = -1;
  // A list kept in parts (entries then empty): per half, where its entries begin. A searched list
  // as the search left it (NeighborList::point_to_halves) also has their nearest distances.
  std::span<const NeighborList::Entry* const> half_entries = {};
  std::span<const NeighborList::NearestDistance* const> half_nearest = {};

  const NeighborList::Entry* entries_of(int h) const {
    return half_entries.empty() ? entries.data() + half_start[h] : half_entries[h];
  }
  std::size_t size() const { return half_start.empty() ? 0 : half_start.back(); }
};

// A narrowed list, kept where each thread of the narrowing wrote its run of halves: copying the
// parts into one array would cost a pass over them and a second list's memory.
struct PairListEntries {
  std::vector<std::vector<NeighborList::Entry>> parts;
  std::vector<int> part_begin, part_end;  // part t holds halves [part_begin[t], part_end[t])
  std::vector<int> half_start;
  std::vector<const NeighborList::Entry*> half_entries;  // into the parts
  long id = -1;

  PairListEntries() = default;
  PairListEntries(const PairListEntries& other) { *this = other; }
  PairListEntries& operator=(const PairListEntries& other);
  PairListEntries(PairListEntries&&) = default;  // moving a vector keeps its elements where they are
  PairListEntries& operator=(PairListEntries&&) = default;

  void point_to_parts();
  PairListView view() const { return {{}, half_start, id, half_entries}; }
};

// A variational step's list (see the top of this file), kept from step to step.
struct StepList {
  PairListEntries list;
  Coords at;               // the step's start
  double skin = 0;         // nm; 0: the fixed pair set, whose masks alone decide
  double reach = 0;        // largest displacement from the start of this step's evaluations so far
  double last_reach = -1;  // the same for the last step (< 0: no step yet)
  long build = -1;         // the search its entries come from
};

class PairLists {
 public:
  // search_skin ≥ skin; equal: no pruning.
  // exclusions, leading: as NeighborList's.
  PairLists(const Box& box, double cutoff, double search_skin, double skin, std::vector<std::vector<int>> exclusions,
            std::vector<char> leading = {});

  // Searches or prunes the regular list unless every atom is within `allowed` of where it was
  // pruned (searched, without pruning), so that it holds every pair within
  // cut-off + skin − 2·allowed at q. single: prune on single-precision distances (cheaper; the
  // range is widened by their rounding).
  void keep_regular(const Coords& q, bool single) { keep_regular(q, 0.5 * skin_, single); }
  // Starts a step at q: the pairs inside the cut-off at q (fixed), or a buffered step list.
  void start_step(StepList& step, const Coords& q, bool fixed, bool single);
  // Keeps a buffered step list valid at q: prunes it again there beyond half its skin.
  void keep_step(StepList& step, const Coords& q, bool single);

  const NeighborList& searched() const { return list_; }
  // The regular list: the pruned one, or the searched one without pruning. Its buffer is skin().
  PairListView regular() const {
    return pruning() ? pruned_.view() : PairListView{list_.entries(), list_.half_start(), searched_id_};
  }
  // The regular list's entries by half (empty before its first pruning), without assembling a
  // searched list's entries.
  std::span<const int> regular_half_start() const { return pruning() ? pruned_.half_start : list_.half_start(); }
  // Buffers of the pruned and the searched list (equal: no pruning), nm.
  double skin() const { return skin_; }
  double search_skin() const { return list_.skin(); }

  void add_work(WorkCounters& counters) const;
  // Checkpoints: the search's and the pruning's positions (the list's order is the summation order).
  void save(Carried& out) const;
  void restore(const Carried& in, bool single);

 private:
  bool pruning() const { return list_.skin() > skin_; }
  // The searched list where the search left it (for a pruning).
  PairListView searched_halves() {
    list_.point_to_halves(half_entries_, half_nearest_);
    return {{}, list_.half_start(), searched_id_, half_entries_, half_nearest_};
  }
  void keep_regular(const Coords& q, double allowed, bool single);
  // Searches again unless every atom is within `allowed` of the last search.
  void search(const Coords& q, double allowed);
  void prune(const Coords& q, bool single);
  // The entries of `from` with a listed pair closer than `range` at q, their masks narrowed to
  // those pairs, into `to`. Where from has nearest distances (a searched list),
  // entries that half_skip_ and cluster_moved_ put beyond the range are dropped unseen. single:
  // compare single-precision distances (the range is widened by their rounding).
  void narrow(const PairListView& from, const Coords& q, double range, bool single, PairListEntries& to);
  // The step list at q with buffer `skin` (0: the pairs inside the cut-off).
  void prune_step(StepList& step, const Coords& q, double skin, bool single);
  double step_skin_after(double reach) const;

  double skin_;
  NeighborList list_;
  long searched_id_ = -1;
  PairListEntries pruned_;
  Coords pruned_at_;
  long prunes_ = 0, step_prunes_ = 0, changes_ = 0;
  double prune_seconds_ = 0;
  std::vector<const NeighborList::Entry*> half_entries_;  // searched_halves()'s
  std::vector<const NeighborList::NearestDistance*> half_nearest_;
  // For a pruning: per half, the range plus the largest displacement of its atoms since the
  // search; per cluster, that displacement (nm, rounded up: PairPositionsOf).
  std::vector<float> half_skip_, cluster_moved_;
  std::vector<double> x_, y_, z_;           // positions packed for a pruning
  std::vector<float> x_single_, y_single_, z_single_;
};

}  // namespace vimd
