#pragma once
// Buffered cluster-pair Verlet list (the GROMACS "nbnxm" layout, simplified).
//
// Atoms are binned into x-y columns, sorted by z inside each column and cut into clusters of
// kClusterSize atoms (the last cluster of a column is padded); inside each half-cluster, atoms
// marked as leading come first. The list holds, for every
// half-cluster i (kHalfSize atoms), the j-clusters with an atom within cutoff + skin of one of
// its atoms, each with a periodic shift and a bit mask of those atom pairs (padding, exclusions
// and double counting removed). Every atom pair is listed once, under the half whose cluster comes
// first: a half's j-clusters are its own and later ones (the pair loop relies on it).
//
// Positions are never wrapped by the integrators. At a build each atom gets the image offset that
// puts it into the box; the same offsets are used until the next build, so the packed
// coordinates move continuously and one shift per cluster pair stays valid. The list is rebuilt
// when any atom has moved more than skin/2 since the last build, so a pair inside the cut-off is
// never missed. Small or non-periodic systems need no special case: with few columns the search
// simply visits all cluster pairs (all periodic images within reach included).
#include <cstdint>
#include <limits>
#include <span>
#include <vector>

#include "engine/box.hpp"
#include "forcefields/nonbonded/cluster_pair_kernels.hpp"
#include "engine/types.hpp"

namespace vimd {

// Largest distance any atom moved between a and b (same atoms), nm.
double max_displacement(const Coords& a, const Coords& b);

// The largest list buffer up to `skin` that the box allows: every pair within cutoff + buffer must
// have one image only, so 2 (cutoff + buffer) may not exceed a box length. A box shorter than twice
// the cut-off allows none (0; the input check refuses it).
double skin_fitting_box(const Box& box, double cutoff, double skin);

// A bound on the error of a distance computed in single precision from coordinates and shifts
// below `magnitude` in size (nm): a few roundings of each coordinate difference, of its square and
// of the sum, each at most one float epsilon of its operand, with room.
inline double single_precision_rounding(double magnitude) {
  return 16 * std::numeric_limits<float>::epsilon() * magnitude;
}

class NeighborList {
 public:
  // j-cluster: 8 atoms, one AVX-512 vector of doubles, two AVX2 or four SSE vectors (the kernels
  // take it in vectors of their target's width); 4 x 8 pair bits fit an entry's 32-bit mask.
  static constexpr int kClusterSize = 8;
  static constexpr int kHalfSize = kClusterSize / 2;

  // Eight bytes, so that a list streams through the caches at half the size of four fields.
  struct Entry {
    static constexpr int kShiftBits = 8;  // with kClusterBits: one 32-bit word
    static constexpr int kClusterBits = 32 - kShiftBits;
    std::uint32_t cluster_and_shift;  // j_cluster << kShiftBits | shift
    std::uint32_t mask;  // bit (ii * kClusterSize + jj): i-half atom ii interacts with j atom jj, and their
                         // distance at the build was below cutoff + skin
    static Entry make(int j_cluster, int shift, std::uint32_t mask) {
      return {static_cast<std::uint32_t>(j_cluster) << kShiftBits | static_cast<std::uint32_t>(shift), mask};
    }
    int j_cluster() const { return static_cast<int>(cluster_and_shift >> kShiftBits); }
    // Index into shift_vectors(); the j atoms are taken at x_j + shift.
    int shift() const { return static_cast<int>(cluster_and_shift & ((1u << kShiftBits) - 1)); }
  };
  // An excluded atom pair (i < j in atom order) in slot indices, with the shift that gives its
  // minimum image; kept for interactions that act on excluded pairs (reaction-field correction).
  struct ExcludedPair {
    int i_slot, j_slot, shift;
  };

  // exclusions[i]: atoms that have no nonbonded interaction with atom i (System::exclusions).
  // leading[i] != 0 (optional): atom i goes before the others of its half-cluster. The pair kernels
  // skip a row vector of i atoms none of which has Lennard-Jones: with those atoms first, fewer row
  // vectors hold one (GROMACS sorts its i-clusters the same way).
  // Throws InputError if a periodic box length is shorter than twice the cut-off.
  NeighborList(const Box& box, double cutoff, double skin, std::vector<std::vector<int>> exclusions,
               std::vector<char> leading = {});

  // Rebuilds when an atom has moved more than `allowed` nm since the last build (or never was
  // built). skin/2 keeps every pair inside the cut-off listed; a pruned list (forcefields/nonbonded/pair_lists.hpp)
  // allows less, so that its inner range stays covered. Returns the largest displacement since
  // the build (0 after a rebuild).
  double update(const Coords& q, double allowed);
  void build(const Coords& q);
  long builds() const { return builds_; }
  // Wall time spent in build(), s (the cost reports show it per step).
  double build_seconds() const { return build_seconds_; }
  // Positions of the last build (empty before the first).
  const Coords& built_at() const { return q_at_build_; }

  double cutoff() const { return cutoff_; }
  double skin() const { return skin_; }
  const Box& box() const { return box_; }

  // Layout of the last build. Slot s = c * kClusterSize + k holds atom slot_atom()[s] (−1: padding).
  int n_atoms() const { return n_atoms_; }
  int n_clusters() const { return n_clusters_; }
  int n_slots() const { return n_clusters_ * kClusterSize; }
  int n_halves() const { return 2 * n_clusters_; }
  const std::vector<int>& slot_atom() const { return slot_atom_; }
  const std::vector<int>& atom_slot() const { return atom_slot_; }

  // The threads' shares (share_begin) of the slots and of the atoms, for the thread count of the
  // last build: thread t's slots listed in the order of their atoms (padding last), and its atoms in
  // the order of their slots. A thread that gathers from arrays in the other order then reads them
  // in sequence, a run of lines the prefetcher follows, instead of jumping: at 2 threads half those
  // lines were last written by the other core. Null for another thread count (plain order then).
  const int* share_slots_by_atom(int threads) const;
  const int* share_atoms_by_slot(int threads) const;

  // Positions in slot order, each shifted by its atom's build-time image offset (SoA; padding 0).
  // Both packers split the slots in shares and end with a barrier: called inside a parallel region
  // they share the work, called outside one they run on the calling thread.
  // Real: double, or float for the mixed-precision kernels.
  template <class Real>
  void pack_positions(const Coords& q, Real* x, Real* y, Real* z) const;
  // Any per-atom 3-vector (e.g. the direction of a Hessian–vector product) in slot order, unshifted.
  template <class Real>
  void pack_vectors(const Coords& u, Real* x, Real* y, Real* z) const;

  // An entry's nearest distance: at the build, no two of its atoms were closer than this many
  // kNearestUnit (rounded down; 2 nm and beyond count as 2 nm, still a lower bound). Half the bytes of
  // a float, for the largest array the search keeps; the unit, a power of two, decodes exactly.
  using NearestDistance = std::uint16_t;
  static constexpr float kNearestUnit = 1.0f / 32768;  // nm
  static NearestDistance encode_nearest(float distance);

  // The entries of i-half h, by shift, then by j-cluster, are numbered half_start()[h] ..
  // half_start()[h + 1] − 1 (per-entry data such as masks go by these numbers). They stay where the
  // search's threads wrote them: point_to_halves gives where each half's entries and their nearest
  // distances begin; valid until the next build, or a copy of the list. entries() and nearest() put
  // them in one array in that order, on first use after a build (a pruning does without: it reads
  // the halves).
  const std::vector<int>& half_start() const { return half_start_; }
  void point_to_halves(std::vector<const Entry*>& entries, std::vector<const NearestDistance*>& nearest) const;
  const std::vector<Entry>& entries() const;
  const std::vector<NearestDistance>& nearest() const;
  const std::vector<Vec3>& shift_vectors() const { return shift_vectors_; }
  const std::vector<ExcludedPair>& excluded_pairs() const { return excluded_pairs_; }

 private:
  struct Bounds {
    Vec3 lo, hi;
  };
  // The layout of a build: bin_atoms does these in order.
  void bin_atoms(const Coords& q);
  void wrap_positions(const Coords& q, Vec3& extent);
  void choose_columns(const Vec3& extent);
  std::vector<int> sort_into_columns(std::vector<int>& column_atom_start) const;
  void assign_slots(const std::vector<int>& sorted, const std::vector<int>& column_atom_start);
  void set_search_positions();
  void group_half_exclusions();
  void compute_bounds();
  // The search: every i-cluster's halves against the clusters of the columns in range, per shift.
  struct SearchInputs;
  struct FoundEntries {  // one i-cluster's, per half
    std::vector<Entry> entries[2];
    std::vector<NearestDistance> nearest[2];
  };
  void search_pairs();
  // The columns within list_range of the bounds moved by −shift, c_lo[k]..c_hi[k]; false if none.
  bool column_range(const Bounds& bounds, const Vec3& shift, double list_range, int c_lo[2], int c_hi[2]) const;
  void search_cluster(int a_cluster, const SearchInputs& in, FoundEntries& found) const;
  void collect_excluded_pairs();
  void order_shares();
  // x, y, z[slot of a] = value(a) for every atom a, and 0 at the padding (the packers' work).
  template <class Real, class Value>
  void pack(Real* x, Real* y, Real* z, Value&& value) const;
  // Entry masks of the two i-halves of i_cluster against j_cluster + shift, from the pairs near
  // each other (bit i * 8 + j, as the search kernel gives them).
  void entry_masks(int i_cluster, int j_cluster, int shift_index, std::uint64_t near, std::uint32_t masks[2]) const;

  Box box_;
  double cutoff_, skin_;
  std::vector<int> exclusion_start_, excluded_atoms_;  // atom a's at [start[a], start[a + 1]); none: empty
  std::span<const int> excluded_by(int a) const {
    if (exclusion_start_.empty()) return {};
    return {excluded_atoms_.data() + exclusion_start_[a], excluded_atoms_.data() + exclusion_start_[a + 1]};
  }
  std::vector<char> leading_;

  int n_atoms_ = 0;
  long builds_ = 0;
  double build_seconds_ = 0;
  Coords q_at_build_;
  Coords image_offset_;  // per atom: wrapped = q − image_offset
  Coords wrapped_;       // per atom, at the last build

  // Grid of x-y columns over [grid_lo, grid_lo + n_columns * column_width).
  Vec3 grid_lo_ = Vec3::Zero();
  double column_width_[2] = {1, 1};
  int n_columns_[2] = {1, 1};
  std::vector<int> column_cluster_start_;  // clusters of column c: [start[c], start[c + 1])

  int n_clusters_ = 0;
  std::vector<int> slot_atom_, atom_slot_;
  int share_threads_ = 0;  // the thread count the two orders below are for
  std::vector<int> share_slots_by_atom_, share_atoms_by_slot_;
  std::vector<float> slot_wrapped_[3];       // wrapped build positions in slot order, for the search
  double search_rounding_ = 0;               // nm: bound on the error of the search's distances
  std::vector<unsigned> cluster_occupancy_;  // per cluster: bit k set if slot k holds an atom
  struct ClusterBits {
    int j_cluster;
    std::uint32_t mask;
  };
  std::vector<std::uint32_t> half_rows_;   // per i-half: 0xff in each row that holds an atom
  std::vector<int> half_exclusion_start_;  // per i-half: its excluded pairs by j-cluster
  std::vector<ClusterBits> half_exclusions_;
  std::vector<double> cluster_lo_[3], cluster_hi_[3];  // cluster bounding boxes, SoA
  std::vector<Bounds> cluster_bounds_;
  std::vector<int> shift_index_range_;  // per dimension: images −m..m are searched
  std::vector<Vec3> shift_vectors_;
  std::vector<Eigen::Vector3i> shift_images_;
  int zero_shift_ = 0;
  std::vector<int> half_start_ = {0};  // a list without halves before the first build
  // Per thread: the entries and nearest distances of the halves it searched, in chunks of about
  // kSearchChunkEntries (kept from search to search: no regrowing); half h's are at half_place_[h].
  static constexpr std::size_t kSearchChunkEntries = std::size_t{1} << 15;
  struct SearchChunk {
    std::vector<Entry> entries;
    std::vector<NearestDistance> nearest;
  };
  struct HalfPlace {
    int thread = 0, chunk = 0, offset = 0;
  };
  std::vector<std::vector<SearchChunk>> search_chunks_;
  std::vector<HalfPlace> half_place_;
  // Appends one i-cluster's entries to this thread's chunks (a new chunk when the current one is full).
  void store_found(int a_cluster, int thread, const FoundEntries& found, std::vector<SearchChunk>& chunks, int& chunk);
  const SearchChunk& chunk_of(std::size_t h) const {
    return search_chunks_[half_place_[h].thread][half_place_[h].chunk];
  }
  const Entry* half_entries(std::size_t h) const { return chunk_of(h).entries.data() + half_place_[h].offset; }
  const NearestDistance* half_nearest(std::size_t h) const {
    return chunk_of(h).nearest.data() + half_place_[h].offset;
  }
  void assemble() const;
  mutable long assembled_build_ = -1;
  mutable std::vector<Entry> entries_;
  mutable std::vector<NearestDistance> nearest_;
  std::vector<ExcludedPair> excluded_pairs_;
};

}  // namespace vimd
