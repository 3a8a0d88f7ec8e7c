#include "forcefields/nonbonded/neighbor_list.hpp"

#include <chrono>
#include <omp.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <numeric>
#include <sstream>
#include <stdexcept>

#include "simd/atom_kernels.hpp"
#include "engine/errors.hpp"

namespace vimd {

namespace {

constexpr int kCluster = NeighborList::kClusterSize;

// A search (binning, bounds, exclusion masks, then a few hundred distance tests per atom) does far
// more per atom, and the other threads would wait through its serial parts: it shares from fewer.
constexpr int kParallelSearchAtoms = 1024;
constexpr int kHalf = NeighborList::kHalfSize;
// Where padding slots sit in the search (nm): slot s at kFarAway (1 + s), far from everything,
// each other included, so that no distance to them counts (nor is the nearest).
constexpr float kFarAway = 1e6f;

// The half list keeps an image of a cluster paired with itself only for one of ±shift.
bool is_positive_image(const Eigen::Vector3i& n) {
  for (int k = 0; k < 3; ++k)
    if (n[k] != 0) return n[k] > 0;
  return false;
}

// Per-half results built by several threads, put in half order, so that the result does not depend
// on which thread did which half: half h's start[h + 1] − start[h] items begin at items_of(h), and go
// to start[h] of `out`.
template <class T, class ItemsOf>
void gather_in_half_order(ItemsOf&& items_of, const std::vector<int>& start, std::vector<T>& out, bool parallel) {
  out.resize(start.back());
  const int n_halves = static_cast<int>(start.size()) - 1;
#pragma omp parallel for schedule(static) if (parallel)
  for (int h = 0; h < n_halves; ++h) std::copy_n(items_of(h), start[h + 1] - start[h], out.begin() + start[h]);
}

// The same where start[h + 1] holds half h's count on entry, and its items are at offset[h] of
// per_thread[owner[h]]: on return start holds where each begins.
template <class T>
void assemble_in_half_order(const std::vector<std::vector<T>>& per_thread, const std::vector<int>& owner,
                            const std::vector<int>& offset, std::vector<int>& start, std::vector<T>& out,
                            bool parallel) {
  std::partial_sum(start.begin(), start.end(), start.begin());
  gather_in_half_order([&](int h) { return per_thread[owner[h]].data() + offset[h]; }, start, out, parallel);
}

}  // namespace

NeighborList::NeighborList(const Box& box, double cutoff, double skin, std::vector<std::vector<int>> exclusions,
                           std::vector<char> leading)
    : box_(box), cutoff_(cutoff), skin_(skin), leading_(std::move(leading)) {
  // One flat array: the searches look the lists up in slot order, i.e. at random atoms.
  if (!exclusions.empty()) {
    exclusion_start_.assign(exclusions.size() + 1, 0);
    for (std::size_t a = 0; a < exclusions.size(); ++a) {
      exclusion_start_[a + 1] = exclusion_start_[a] + static_cast<int>(exclusions[a].size());
      excluded_atoms_.insert(excluded_atoms_.end(), exclusions[a].begin(), exclusions[a].end());
    }
  }
  if (!(cutoff > 0)) throw SettingError("forcefield", "cutoff", "cutoff must be positive");
  if (!(skin >= 0)) throw SettingError("forcefield", "neighbor_skin", "neighbor_skin must not be negative");
  const double list_range = cutoff + skin;
  static const char* axis = "xyz";
  for (int k = 0; k < 3; ++k) {
    const double length = box.length[k];
    if (length < 0) throw InputError("box", 0, std::string("negative box length in ") + axis[k]);
    // With L ≥ 2 rc each pair has at most one image inside the cut-off (minimum image convention).
    if (length > 0 && length < 2 * cutoff) {
      std::ostringstream msg;
      msg << "box length " << length << " nm in " << axis[k] << " is shorter than twice the cut-off (" << cutoff
          << " nm)";
      throw InputError("box", 0, msg.str());
    }
    // Wrapped positions lie in [0, L): images up to ceil(r_list / L) boxes away can be in range.
    shift_index_range_.push_back(length > 0 ? static_cast<int>(std::ceil(list_range / length)) : 0);
  }
  const int mx = shift_index_range_[0], my = shift_index_range_[1], mz = shift_index_range_[2];
  zero_shift_ = ((2 * mx + 1) * (2 * my + 1) * (2 * mz + 1)) / 2;  // (0,0,0) is the middle image
  for (int sx = -mx; sx <= mx; ++sx)
    for (int sy = -my; sy <= my; ++sy)
      for (int sz = -mz; sz <= mz; ++sz) {
        shift_images_.emplace_back(sx, sy, sz);
        shift_vectors_.emplace_back(sx * box.length[0], sy * box.length[1], sz * box.length[2]);
      }
  // A run's buffer fits the box (skin_fitting_box), which leaves 27 images at most.
  if (shift_vectors_.size() > (std::size_t{1} << Entry::kShiftBits))
    throw std::invalid_argument("NeighborList: " + std::to_string(shift_vectors_.size()) +
                                " periodic images in reach, more than an entry can name");
}

double skin_fitting_box(const Box& box, double cutoff, double skin) {
  // The same test as the input check's, so that a skin that fits is kept exactly.
  for (int k = 0; k < 3; ++k)
    if (box.length[k] > 0 && box.length[k] < 2 * (cutoff + skin)) skin = 0.5 * box.length[k] - cutoff;
  return std::max(skin, 0.0);
}

double max_displacement(const Coords& a, const Coords& b) {
  if (a.cols() != b.cols()) return INFINITY;
  const MaxSquaredDisplacementKernel kernel = simd::max_squared_displacement_kernel();
  std::vector<double> largest(omp_get_max_threads(), 0.0);
  for_atom_shares(static_cast<int>(a.cols()), [&](int first, int count) {
    largest[omp_get_thread_num()] = kernel(count, a.data() + 3 * first, b.data() + 3 * first);
  });
  return std::sqrt(*std::max_element(largest.begin(), largest.end()));
}

double NeighborList::update(const Coords& q, double allowed) {
  const double moved = builds_ > 0 ? max_displacement(q, q_at_build_) : INFINITY;
  if (moved <= allowed) return moved;
  build(q);
  return 0;
}

void NeighborList::build(const Coords& q) {
  const int excluding_atoms = static_cast<int>(exclusion_start_.size()) - 1;
  if (excluding_atoms >= 0 && excluding_atoms != q.cols())
    throw std::invalid_argument("NeighborList: exclusion lists for " + std::to_string(excluding_atoms) +
                                " atoms, positions for " + std::to_string(q.cols()));
  const auto start = std::chrono::steady_clock::now();
  n_atoms_ = static_cast<int>(q.cols());
  q_at_build_ = q;
  bin_atoms(q);
  compute_bounds();
  search_pairs();
  collect_excluded_pairs();
  order_shares();
  ++builds_;
  build_seconds_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

void NeighborList::bin_atoms(const Coords& q) {
  Vec3 extent;
  wrap_positions(q, extent);
  choose_columns(extent);
  std::vector<int> column_atom_start;
  const std::vector<int> sorted = sort_into_columns(column_atom_start);
  assign_slots(sorted, column_atom_start);
  set_search_positions();
  group_half_exclusions();
}

// wrapped_ = q moved into the box along its periodic directions (image_offset_ = q − wrapped_);
// grid_lo_ and extent: the region the grid covers (the box, or the atoms' span where not periodic).
void NeighborList::wrap_positions(const Coords& q, Vec3& extent) {
  const int n = n_atoms_;
  wrapped_.resize(3, n);
  image_offset_.resize(3, n);
  for (int k = 0; k < 3; ++k) {
    const double length = box_.length[k];
    if (length > 0) {
      for (int i = 0; i < n; ++i) {
        double image = std::floor(q(k, i) / length) * length;
        double w = q(k, i) - image;
        if (w >= length) {  // rounding can put w at exactly L
          w -= length;
          image += length;
        }
        wrapped_(k, i) = w;
        image_offset_(k, i) = image;
      }
      grid_lo_[k] = 0;
      extent[k] = length;
    } else {
      wrapped_.row(k) = q.row(k);
      image_offset_.row(k).setZero();
      grid_lo_[k] = n > 0 ? q.row(k).minCoeff() : 0;
      extent[k] = n > 0 ? q.row(k).maxCoeff() - grid_lo_[k] : 0;
    }
  }
}

// Columns about as wide as a cubic cluster of kClusterSize atoms at the mean density.
void NeighborList::choose_columns(const Vec3& extent) {
  const int n = n_atoms_;
  constexpr double kMinExtent = 1e-3;  // nm; keeps the density finite for flat or single-atom systems
  const double volume =
      std::max(extent[0], kMinExtent) * std::max(extent[1], kMinExtent) * std::max(extent[2], kMinExtent);
  const double cluster_side = std::cbrt(kCluster * volume / std::max(n, 1));
  const int max_columns = std::max(1, n / kCluster);
  for (int k = 0; k < 2; ++k)
    n_columns_[k] = std::clamp(static_cast<int>(std::lround(extent[k] / cluster_side)), 1, max_columns);
  while (n_columns_[0] * n_columns_[1] > max_columns) {
    int& larger = n_columns_[0] >= n_columns_[1] ? n_columns_[0] : n_columns_[1];
    larger = std::max(1, larger / 2);
  }
  for (int k = 0; k < 2; ++k) column_width_[k] = extent[k] > 0 ? extent[k] / n_columns_[k] : 1.0;
}

// The atoms by column, each column's by z (leading atoms first within each half-cluster's run
// where given); column c's are [column_atom_start[c], column_atom_start[c + 1]).
std::vector<int> NeighborList::sort_into_columns(std::vector<int>& column_atom_start) const {
  const int n = n_atoms_;
  const int n_columns = n_columns_[0] * n_columns_[1];
  std::vector<int> column_of(n);
  std::vector<int> column_count(n_columns + 1, 0);
  for (int i = 0; i < n; ++i) {
    int c[2];
    for (int k = 0; k < 2; ++k)
      c[k] = std::clamp(static_cast<int>((wrapped_(k, i) - grid_lo_[k]) / column_width_[k]), 0, n_columns_[k] - 1);
    column_of[i] = c[0] * n_columns_[1] + c[1];
    ++column_count[column_of[i] + 1];
  }
  column_atom_start.assign(n_columns + 1, 0);
  std::partial_sum(column_count.begin(), column_count.end(), column_atom_start.begin());
  std::vector<int> sorted(n);
  {
    std::vector<int> fill(column_atom_start.begin(), column_atom_start.end() - 1);
    for (int i = 0; i < n; ++i) sorted[fill[column_of[i]]++] = i;
  }
#pragma omp parallel for schedule(dynamic, 16) if (n >= kParallelSearchAtoms)
  for (int c = 0; c < n_columns; ++c) {
    const auto begin = sorted.begin() + column_atom_start[c], end = sorted.begin() + column_atom_start[c + 1];
    std::sort(begin, end, [&](int a, int b) {
      return wrapped_(2, a) < wrapped_(2, b) || (wrapped_(2, a) == wrapped_(2, b) && a < b);
    });
    if (leading_.empty()) continue;
    for (auto half = begin; half < end; half += std::min<std::ptrdiff_t>(kHalf, end - half))
      std::stable_partition(half, half + std::min<std::ptrdiff_t>(kHalf, end - half),
                            [&](int a) { return leading_[a] != 0; });
  }
  return sorted;
}

// Each column's atoms fill whole clusters of their own, in sorted order: slot_atom_, atom_slot_,
// column_cluster_start_, n_clusters_.
void NeighborList::assign_slots(const std::vector<int>& sorted, const std::vector<int>& column_atom_start) {
  const int n = n_atoms_;
  const int n_columns = n_columns_[0] * n_columns_[1];
  column_cluster_start_.assign(n_columns + 1, 0);
  for (int c = 0; c < n_columns; ++c) {
    const int atoms = column_atom_start[c + 1] - column_atom_start[c];
    column_cluster_start_[c + 1] = column_cluster_start_[c] + (atoms + kCluster - 1) / kCluster;
  }
  n_clusters_ = column_cluster_start_[n_columns];
  if (n_clusters_ >= (1 << Entry::kClusterBits))
    throw SettingError("system", "structure",
                       std::to_string(n) + " atoms need " + std::to_string(n_clusters_) + " pair-list clusters; at most " +
                           std::to_string((1 << Entry::kClusterBits) - 1) + " fit the list's entries");
  slot_atom_.assign(static_cast<std::size_t>(n_clusters_) * kCluster, -1);
  atom_slot_.assign(n, -1);
  for (int c = 0; c < n_columns; ++c) {
    const int first_slot = column_cluster_start_[c] * kCluster;
    for (int k = column_atom_start[c]; k < column_atom_start[c + 1]; ++k) {
      const int slot = first_slot + (k - column_atom_start[c]);
      slot_atom_[slot] = sorted[k];
      atom_slot_[sorted[k]] = slot;
    }
  }
}

// The search's single-precision positions in slot order (padding far away, each slot elsewhere),
// which slots hold atoms, and the bound on the rounding of the distances computed from them.
void NeighborList::set_search_positions() {
  const int n = n_atoms_;
  cluster_occupancy_.assign(n_clusters_, 0u);
  for (auto& w : slot_wrapped_) w.resize(slot_atom_.size());
  for (int s = 0; s < n_slots(); ++s) {
    const int a = slot_atom_[s];
    if (a < 0) {
      for (auto& w : slot_wrapped_) w[s] = kFarAway * static_cast<float>(1 + s);
      continue;
    }
    cluster_occupancy_[s / kCluster] |= 1u << (s % kCluster);
    for (int k = 0; k < 3; ++k) slot_wrapped_[k][s] = static_cast<float>(wrapped_(k, a));
  }
  double largest = 0;
  for (int k = 0; k < 3; ++k)
    if (n > 0) largest = std::max(largest, wrapped_.row(k).cwiseAbs().maxCoeff());
  double largest_shift = 0;
  for (const Vec3& shift : shift_vectors_) largest_shift = std::max(largest_shift, shift.cwiseAbs().maxCoeff());
  search_rounding_ = single_precision_rounding(largest + largest_shift + cutoff_ + skin_);
}

// Per i-half: which rows hold atoms, and the excluded pairs grouped by j-cluster (a water half
// has its partners in one or two clusters), so that a mask needs only a few comparisons. Each
// thread groups its halves' pairs in its own buffer (the lookups miss the cache: the atoms of a
// half are far apart in atom order).
void NeighborList::group_half_exclusions() {
  const int n = n_atoms_;
  const int n_halves = this->n_halves();
  half_rows_.assign(n_halves, 0u);
  half_exclusion_start_.assign(n_halves + 1, 0);
  std::vector<int> owner(n_halves), offset(n_halves);
  std::vector<std::vector<ClusterBits>> per_thread(omp_get_max_threads());
#pragma omp parallel if (n >= kParallelSearchAtoms)
  {
    const int t = omp_get_thread_num();
    std::vector<ClusterBits>& out = per_thread[t];
#pragma omp for schedule(static)
    for (int h = 0; h < n_halves; ++h) {
      const std::size_t first = out.size();
      for (int ii = 0; ii < kHalf; ++ii) {
        const int a = slot_atom_[h * kHalf + ii];
        if (a < 0) continue;
        half_rows_[h] |= 0xffu << (ii * kCluster);
        for (int p : excluded_by(a)) {
          if (p == a) continue;
          const int ps = atom_slot_[p];
          const std::uint32_t bit = 1u << (ii * kCluster + ps % kCluster);
          auto it = std::find_if(out.begin() + first, out.end(),
                                 [&](const ClusterBits& c) { return c.j_cluster == ps / kCluster; });
          if (it == out.end())
            out.push_back({ps / kCluster, bit});
          else
            it->mask |= bit;
        }
      }
      owner[h] = t;
      offset[h] = static_cast<int>(first);
      half_exclusion_start_[h + 1] = static_cast<int>(out.size() - first);
    }
  }
  assemble_in_half_order(per_thread, owner, offset, half_exclusion_start_, half_exclusions_, n >= kParallelSearchAtoms);
}

void NeighborList::compute_bounds() {
  for (int k = 0; k < 3; ++k) {  // padded by one batch of empty boxes for the search
    cluster_lo_[k].assign(n_clusters_ + kBoxBatch, INFINITY);
    cluster_hi_[k].assign(n_clusters_ + kBoxBatch, -INFINITY);
  }
  cluster_bounds_.resize(n_clusters_);
#pragma omp parallel for schedule(static) if (n_atoms_ >= kParallelSearchAtoms)
  for (int c = 0; c < n_clusters_; ++c) {
    Bounds b{Vec3::Constant(INFINITY), Vec3::Constant(-INFINITY)};
    for (int s = c * kCluster; s < (c + 1) * kCluster; ++s) {
      const int a = slot_atom_[s];
      if (a < 0) continue;
      b.lo = b.lo.cwiseMin(wrapped_.col(a));
      b.hi = b.hi.cwiseMax(wrapped_.col(a));
    }
    cluster_bounds_[c] = b;
    for (int k = 0; k < 3; ++k) {
      cluster_lo_[k][c] = b.lo[k];
      cluster_hi_[k][c] = b.hi[k];
    }
  }
}

inline void NeighborList::entry_masks(int i_cluster, int j_cluster, int shift_index, std::uint64_t near,
                                      std::uint32_t masks[2]) const {
  // Real atoms on both sides; inside one cluster each pair once (j > i) and never an atom with
  // its own image.
  constexpr std::uint32_t kRowsOf = 0x01010101u;  // one byte per i row
  const std::uint32_t occupied = cluster_occupancy_[j_cluster] * kRowsOf;
  for (int hh = 0; hh < 2; ++hh) {
    const int i_half = 2 * i_cluster + hh;
    std::uint32_t mask = static_cast<std::uint32_t>(near >> (hh * 32)) & occupied & half_rows_[i_half];
    if (j_cluster == i_cluster) {
      // Bit (ii, jj) of i-half hh is the pair of cluster slots (4 hh + ii, jj).
      static constexpr std::uint32_t kAbove[2] = {0xf0f8fcfeu, 0x0080c0e0u};        // jj > 4 hh + ii
      static constexpr std::uint32_t kOffDiagonal[2] = {0xf7fbfdfeu, 0x7fbfdfefu};  // jj != 4 hh + ii
      mask &= shift_index == zero_shift_ ? kAbove[hh] : kOffDiagonal[hh];
    }
    for (int k = half_exclusion_start_[i_half]; k < half_exclusion_start_[i_half + 1]; ++k)
      if (half_exclusions_[k].j_cluster == j_cluster) mask &= ~half_exclusions_[k].mask;
    masks[hh] = mask;
  }
}

// What every i-cluster's search reads, prepared once per search.
struct NeighborList::SearchInputs {
  double list_range, range2;
  ClusterPairKernel kernel;
  BoxBatchKernel box_batch;
  const double* lo[3];  // cluster bounding boxes
  const double* hi[3];
  const float* x;  // wrapped build positions in slot order
  const float* y;
  const float* z;
  // The atom pairs are tested in single precision: within the range widened by the rounding, so
  // that no pair within it is missed, and `nearest` lowered by it, so that it stays a lower bound.
  float near_range2;
  std::vector<std::array<float, 3>> shift_single;
};

void NeighborList::search_pairs() {
  SearchInputs in;
  in.list_range = cutoff_ + skin_;
  in.range2 = in.list_range * in.list_range;
  in.kernel = simd::cluster_pair_kernel();
  in.box_batch = simd::box_batch_kernel();
  for (int k = 0; k < 3; ++k) in.lo[k] = cluster_lo_[k].data(), in.hi[k] = cluster_hi_[k].data();
  in.x = slot_wrapped_[0].data();
  in.y = slot_wrapped_[1].data();
  in.z = slot_wrapped_[2].data();
  in.near_range2 = static_cast<float>((in.list_range + search_rounding_) * (in.list_range + search_rounding_));
  in.shift_single.resize(shift_vectors_.size());
  for (std::size_t si = 0; si < shift_vectors_.size(); ++si)
    for (int k = 0; k < 3; ++k) in.shift_single[si][k] = static_cast<float>(shift_vectors_[si][k]);

  // Clusters are shared out dynamically (the half list gives early clusters more partners); each
  // thread appends its entries to its own buffer and notes where each half's entries went. The
  // entries stay there (numbered in half order, so nothing depends on the thread count): a pruning
  // reads them by half, and entries() puts them in one array only where a caller asks.
  half_start_.assign(2 * n_clusters_ + 1, 0);
  half_place_.assign(2 * n_clusters_, {});
  search_chunks_.resize(omp_get_max_threads());
#pragma omp parallel if (n_atoms_ >= kParallelSearchAtoms)
  {
    const int t = omp_get_thread_num();
    std::vector<SearchChunk>& chunks = search_chunks_[t];
    if (chunks.empty()) chunks.emplace_back();
    for (SearchChunk& chunk : chunks) chunk.entries.clear(), chunk.nearest.clear();
    int chunk = 0;
    FoundEntries found;
#pragma omp for schedule(dynamic, 8)
    for (int a_cluster = 0; a_cluster < n_clusters_; ++a_cluster) {
      search_cluster(a_cluster, in, found);
      store_found(a_cluster, t, found, chunks, chunk);
    }
  }
  std::partial_sum(half_start_.begin(), half_start_.end(), half_start_.begin());
}

bool NeighborList::column_range(const Bounds& bounds, const Vec3& shift, double list_range, int c_lo[2],
                                int c_hi[2]) const {
  for (int k = 0; k < 2; ++k) {
    const double lo = (bounds.lo[k] - list_range - shift[k] - grid_lo_[k]) / column_width_[k];
    const double hi = (bounds.hi[k] + list_range - shift[k] - grid_lo_[k]) / column_width_[k];
    if (hi < 0 || lo >= n_columns_[k]) return false;
    c_lo[k] = std::max(0, static_cast<int>(std::floor(lo)));
    c_hi[k] = std::min(n_columns_[k] - 1, static_cast<int>(std::floor(hi)));
  }
  return true;
}

void NeighborList::search_cluster(int a_cluster, const SearchInputs& in, FoundEntries& found) const {
  std::uint64_t near[kBoxBatch];
  float nearest[kBoxBatch][2] = {};  // finite from the start: the kernel converts all of it
  // Candidates by the bounding box of the whole i-cluster, then per half.
  const Bounds& ba = cluster_bounds_[a_cluster];
  for (int hh = 0; hh < 2; ++hh) found.entries[hh].clear(), found.nearest[hh].clear();
  // Clusters are numbered column by column, so clusters b ≥ a_cluster live in columns from
  // a_cluster's own column on.
  const int a_column =
      static_cast<int>(std::upper_bound(column_cluster_start_.begin(), column_cluster_start_.end(), a_cluster) -
                       column_cluster_start_.begin() - 1);
  for (int si = 0; si < static_cast<int>(shift_vectors_.size()); ++si) {
    const Vec3& shift = shift_vectors_[si];
    int c_lo[2], c_hi[2];
    if (!column_range(ba, shift, in.list_range, c_lo, c_hi)) continue;
    const bool positive = is_positive_image(shift_images_[si]);
    for (int cx = std::max(c_lo[0], a_column / n_columns_[1]); cx <= c_hi[0]; ++cx)
      for (int cy = c_lo[1]; cy <= c_hi[1]; ++cy) {
        const int column = cx * n_columns_[1] + cy;
        const int column_end = column_cluster_start_[column + 1];
        if (column_end <= a_cluster) continue;
        // Bounding-box distances of kBoxBatch clusters of the column at once.
        for (int b0 = std::max(a_cluster, column_cluster_start_[column]); b0 < column_end; b0 += kBoxBatch) {
          unsigned candidates = in.box_batch(in.lo, in.hi, b0, ba.lo.data(), ba.hi.data(), shift.data(), in.range2);
          if (column_end - b0 < kBoxBatch) candidates &= (1u << (column_end - b0)) - 1;
          // The half list keeps a cluster's own images for one of ±shift only.
          if (b0 == a_cluster && si != zero_shift_ && !positive) candidates &= ~1u;
          if (candidates == 0) continue;
          in.kernel(in.x, in.y, in.z, a_cluster * kCluster, b0, candidates, in.shift_single[si].data(),
                    in.near_range2, static_cast<float>(search_rounding_), near, nearest);
          for (; candidates; candidates &= candidates - 1) {
            const int c = __builtin_ctz(candidates);
            std::uint32_t masks[2];
            entry_masks(a_cluster, b0 + c, si, near[c], masks);
            for (int hh = 0; hh < 2; ++hh)
              if (masks[hh] != 0) {
                found.entries[hh].push_back(Entry::make(b0 + c, si, masks[hh]));
                found.nearest[hh].push_back(encode_nearest(nearest[c][hh]));
              }
          }
        }
      }
  }
}

void NeighborList::store_found(int a_cluster, int thread, const FoundEntries& found, std::vector<SearchChunk>& chunks,
                               int& chunk) {
  // A full chunk is left as it is and the next one taken: one vector of all the entries would
  // copy them as it grew and hold both copies at once, the largest allocation of a run.
  const std::size_t n_found = found.entries[0].size() + found.entries[1].size();
  if (chunks[chunk].entries.size() + n_found > kSearchChunkEntries && !chunks[chunk].entries.empty() &&
      ++chunk == static_cast<int>(chunks.size()))
    chunks.emplace_back();
  SearchChunk& out = chunks[chunk];
  const std::size_t needed = out.entries.size() + n_found;
  if (out.entries.capacity() < needed) {  // doubling, but not past a chunk
    const std::size_t capacity =
        std::min(std::max(2 * out.entries.capacity(), needed), std::max(kSearchChunkEntries, needed));
    out.entries.reserve(capacity);
    out.nearest.reserve(capacity);
  }
  // found is in the search's order: by shift, then by j-cluster (columns and the clusters in each
  // in numbering order), as the pair kernels want it (a run of one shift shifts the i atoms once).
  for (int hh = 0; hh < 2; ++hh) {
    const int h = 2 * a_cluster + hh;
    half_start_[h + 1] = static_cast<int>(found.entries[hh].size());
    half_place_[h] = {thread, chunk, static_cast<int>(out.entries.size())};
    out.entries.insert(out.entries.end(), found.entries[hh].begin(), found.entries[hh].end());
    out.nearest.insert(out.nearest.end(), found.nearest[hh].begin(), found.nearest[hh].end());
  }
}

NeighborList::NearestDistance NeighborList::encode_nearest(float distance) {
  constexpr float kLargest = std::numeric_limits<NearestDistance>::max();
  // The product is exact (a power of two), and so is the floor: the code times the unit is at most
  // the distance. !(x > 0) also sends a NaN to 0.
  const float units = distance * (1 / kNearestUnit);
  return static_cast<NearestDistance>(!(units > 0) ? 0.0f : std::min(std::floor(units), kLargest));
}

void NeighborList::point_to_halves(std::vector<const Entry*>& entries,
                                   std::vector<const NearestDistance*>& nearest) const {
  const std::size_t n_halves = half_place_.size();
  entries.resize(n_halves);
  nearest.resize(n_halves);
  for (std::size_t h = 0; h < n_halves; ++h) {
    entries[h] = half_entries(h);
    nearest[h] = half_nearest(h);
  }
}

const std::vector<NeighborList::Entry>& NeighborList::entries() const {
  assemble();
  return entries_;
}

const std::vector<NeighborList::NearestDistance>& NeighborList::nearest() const {
  assemble();
  return nearest_;
}

void NeighborList::assemble() const {
  if (assembled_build_ == builds_) return;
  const bool parallel = n_atoms_ >= kParallelSearchAtoms;
  gather_in_half_order([&](int h) { return half_entries(h); }, half_start_, entries_, parallel);
  gather_in_half_order([&](int h) { return half_nearest(h); }, half_start_, nearest_, parallel);
  assembled_build_ = builds_;
}

void NeighborList::collect_excluded_pairs() {
  excluded_pairs_.clear();
  const int m[3] = {shift_index_range_[0], shift_index_range_[1], shift_index_range_[2]};
  for (int a = 0; a < static_cast<int>(exclusion_start_.size()) - 1; ++a)
    for (int p : excluded_by(a)) {
      if (p <= a) continue;
      // Image of p nearest to a at the build; positions stay continuous until the next build.
      int image[3];
      for (int k = 0; k < 3; ++k) {
        const double length = box_.length[k];
        image[k] = length > 0 ? static_cast<int>(std::lround((wrapped_(k, a) - wrapped_(k, p)) / length)) : 0;
      }
      const int shift = ((image[0] + m[0]) * (2 * m[1] + 1) + (image[1] + m[1])) * (2 * m[2] + 1) + (image[2] + m[2]);
      excluded_pairs_.push_back({atom_slot_[a], atom_slot_[p], shift});
    }
}

void NeighborList::order_shares() {
  const int nt = omp_get_max_threads(), n_slots = this->n_slots();
  share_threads_ = nt;
  share_slots_by_atom_.resize(n_slots);
  share_atoms_by_slot_.resize(n_atoms_);
  // next[t]: where thread t's list goes on.
  std::vector<int> owner, next(nt);
  const auto start_shares = [&](int n) {
    share_owners(n, nt, owner);
    for (int t = 0; t < nt; ++t) next[t] = share_begin(n, t, nt);
  };
  start_shares(n_slots);
  for (int a = 0; a < n_atoms_; ++a) share_slots_by_atom_[next[owner[atom_slot_[a]]]++] = atom_slot_[a];
  for (int s = 0; s < n_slots; ++s)
    if (slot_atom_[s] < 0) share_slots_by_atom_[next[owner[s]]++] = s;
  start_shares(n_atoms_);
  for (int s = 0; s < n_slots; ++s)
    if (const int a = slot_atom_[s]; a >= 0) share_atoms_by_slot_[next[owner[a]]++] = a;
}

const int* NeighborList::share_slots_by_atom(int threads) const {
  return threads == share_threads_ ? share_slots_by_atom_.data() : nullptr;
}

const int* NeighborList::share_atoms_by_slot(int threads) const {
  return threads == share_threads_ ? share_atoms_by_slot_.data() : nullptr;
}

template <class Real, class Value>
void NeighborList::pack(Real* x, Real* y, Real* z, Value&& value) const {
  // Each thread writes its own run of slots: in atom order the threads' writes would be scattered
  // over the slots and share cache lines.
  const int n_slots = this->n_slots(), t = omp_get_thread_num(), nt = omp_get_num_threads();
  const int* order = share_slots_by_atom(nt);
  for (int i = share_begin(n_slots, t, nt), end = share_begin(n_slots, t + 1, nt); i < end; ++i) {
    const int s = order ? order[i] : i;
    const int a = slot_atom_[s];
    if (a < 0) {
      x[s] = y[s] = z[s] = 0;
      continue;
    }
    const Vec3 v = value(a);
    x[s] = static_cast<Real>(v[0]);
    y[s] = static_cast<Real>(v[1]);
    z[s] = static_cast<Real>(v[2]);
  }
#pragma omp barrier
}

template <class Real>
void NeighborList::pack_positions(const Coords& q, Real* x, Real* y, Real* z) const {
  pack(x, y, z, [&](int a) -> Vec3 { return q.col(a) - image_offset_.col(a); });
}
template void NeighborList::pack_positions(const Coords&, double*, double*, double*) const;
template void NeighborList::pack_positions(const Coords&, float*, float*, float*) const;

template <class Real>
void NeighborList::pack_vectors(const Coords& u, Real* x, Real* y, Real* z) const {
  pack(x, y, z, [&](int a) -> Vec3 { return u.col(a); });
}
template void NeighborList::pack_vectors(const Coords&, double*, double*, double*) const;
template void NeighborList::pack_vectors(const Coords&, float*, float*, float*) const;

}  // namespace vimd
