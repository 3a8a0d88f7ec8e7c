// Pruning, for the SIMD target being compiled: which listed pairs of a list's entries are inside a
// range (the mask kernels), and a list narrowed to the entries with such pairs (the narrow kernels),
// as templates on the precision of the positions. A Highway per-target header: see simd/simd-inl.h.
#if defined(VIMD_FORCEFIELDS_NONBONDED_PRUNING_INL_H_) == defined(HWY_TARGET_TOGGLE)
#ifdef VIMD_FORCEFIELDS_NONBONDED_PRUNING_INL_H_
#undef VIMD_FORCEFIELDS_NONBONDED_PRUNING_INL_H_
#else
#define VIMD_FORCEFIELDS_NONBONDED_PRUNING_INL_H_
#endif

#include <algorithm>
#include <array>
#include <cstdint>

#include "forcefields/nonbonded/nonbonded_kernels.hpp"
#include "forcefields/nonbonded/pair_layout-inl.h"
#include "hwy/highway.h"
#include "simd/simd-inl.h"

HWY_BEFORE_NAMESPACE();
namespace vimd {
namespace HWY_NAMESPACE {
namespace {

// The bits of an entry's pairs within the range at the positions (every listed pair is looked at).
template <class Real>
HWY_INLINE std::uint32_t entry_inside_bits(const PairPositionsOf<Real>& d, ShiftedHalf<Real>& positions,
                                           NeighborList::Entry entry, SimdVec<Real> range2) {
  using V = SimdVec<Real>;
  constexpr int kRows = PairLayout<Real>::kRows, kJ = PairLayout<Real>::kJLanes;
  positions.follow(d, entry.shift());
  std::uint32_t inside_bits = 0;
  for (int js = 0; js < kC; js += kJ) {
    const int jb = entry.j_cluster() * kC + js;
    const V xj = load_j(d.x + jb), yj = load_j(d.y + jb), zj = load_j(d.z + jb);
    // Every lane, listed or not (padding and excluded pairs have finite distances too); the
    // entry's mask then keeps the listed pairs: cheaper than a vector mask per row.
    for (int ii = 0; ii < kH; ii += kRows) {
      const V dx = xj - positions.x[ii / kRows], dy = yj - positions.y[ii / kRows], dz = zj - positions.z[ii / kRows];
      inside_bits |= bits_from_mask(dx * dx + dy * dy + dz * dz < range2) << (ii * kC + js);
    }
  }
  return inside_bits & entry.mask;
}

// For each 8-bit lane mask, the lanes it sets in order, 4 bits each (lane 0 in the lowest nibble).
constexpr std::array<std::uint32_t, 256> kSetLanes = [] {
  std::array<std::uint32_t, 256> table{};
  for (unsigned bits = 0; bits < 256; ++bits)
    for (unsigned lane = 0, n = 0; lane < 8; ++lane)
      if (bits & (1u << lane)) table[bits] |= lane << (4 * n++);
  return table;
}();

// Stores the lanes of `values` that `keep` selects to out, in order; returns how many. Writes a
// whole vector at out. Highway's CompressStore does this where the target has it as an
// instruction (AVX-512); its AVX2 version declares its index table as a local constexpr array,
// which GCC copies to the stack (1 KiB) at every call, so up to 8 lanes take kSetLanes instead.
template <class D>
HWY_INLINE int compress_store(D d, hn::Vec<D> values, hn::Mask<D> keep, hn::TFromD<D>* out) {
  if constexpr (hn::MaxLanes(D()) <= 8 && sizeof(hn::TFromD<D>) == 4) {
    const hn::RebindToUnsigned<D> du;
    std::uint8_t byte[8] = {};
    hn::StoreMaskBits(d, keep, byte);
    const auto lanes = hn::And(hn::Shr(hn::Set(du, kSetLanes[byte[0]]), hn::ShiftLeft<2>(hn::Iota(du, 0))),
                               hn::Set(du, 15));
    hn::StoreU(hn::TableLookupLanes(values, hn::IndicesFromVec(d, hn::BitCast(hn::RebindToSigned<D>(), lanes))), d,
               out);
    return static_cast<int>(hwy::PopCount(byte[0]));
  } else {
    return static_cast<int>(hn::CompressStore(values, keep, d, out));
  }
}

// keep(h, k, entry, bits) for the entries of halves [h0, h1) that may have a listed pair inside the
// range, in order: k the entry's place in its half, bits those pairs; then half_done(h). Entries
// that the view's half_skip and cluster_moved put beyond the range are passed over unseen (their
// bits would be 0).
template <class Real, class Keep, class HalfDone>
HWY_INLINE void inside_bits_of_halves(const PairPositionsOf<Real>& d, int h0, int h1, Keep&& keep,
                                      HalfDone&& half_done) {
  using V = SimdVec<Real>;
  const V range2 = V::broadcast(d.cutoff2);
  const hn::CappedTag<float, 16> df;
  const hn::Rebind<std::int32_t, decltype(df)> di;
  const hn::Rebind<std::uint32_t, decltype(df)> du;
  const hn::Rebind<NeighborList::NearestDistance, decltype(df)> dn;
  const auto unit = hn::Set(df, NeighborList::kNearestUnit);
  const auto lane_index = hn::Iota(di, 0);  // not Iota(di, k): its lanes would be stored one by one
  const int lanes = static_cast<int>(hn::Lanes(df));
  static_assert(sizeof(NeighborList::Entry) == 2 * sizeof(std::uint32_t), "Entry: two words");
  constexpr int kBlock = 256;
  HWY_ALIGN std::int32_t look[kBlock];  // a vector's compressed store stays below its own end
  for (int h = h0; h < h1; ++h) {
    ShiftedHalf<Real> positions;
    positions.start(h);
    const int count = d.half_start[h + 1] - d.half_start[h];
    const NeighborList::Entry* entries = entries_of_half(d, h);
    const NeighborList::NearestDistance* nearest = d.half_nearest ? d.half_nearest[h] : nullptr;
    if (!nearest) {
      for (int k = 0; k < count; ++k) keep(h, k, entries[k], entry_inside_bits(d, positions, entries[k], range2));
      half_done(h);
      continue;
    }
    const float half_skip = d.half_skip[h];
    // Which entries are nearer than their skip distance is unpredictable: they are listed first,
    // by vectors, as a branch per entry would cost more than the look itself.
    for (int k0 = 0; k0 < count; k0 += kBlock) {
      const int n = std::min(kBlock, count - k0);
      int m = 0, k = 0;
      for (; k + lanes <= n; k += lanes) {
        hn::Vec<decltype(du)> cluster_and_shift, mask;
        hn::LoadInterleaved2(du, reinterpret_cast<const std::uint32_t*>(entries + k0 + k), cluster_and_shift, mask);
        const auto j_cluster = hn::BitCast(di, hn::ShiftRight<NeighborList::Entry::kShiftBits>(cluster_and_shift));
        const auto skip = hn::Add(hn::Set(df, half_skip), hn::GatherIndex(df, d.cluster_moved, j_cluster));
        const auto units = hn::BitCast(di, hn::PromoteTo(du, hn::LoadU(dn, nearest + k0 + k)));
        const auto near = hn::Lt(hn::Mul(hn::ConvertTo(df, units), unit), skip);
        m += compress_store(di, hn::Add(lane_index, hn::Set(di, k0 + k)), hn::RebindMask(di, near), look + m);
      }
      for (; k < n; ++k) {
        look[m] = k0 + k;
        m += nearest[k0 + k] * NeighborList::kNearestUnit < half_skip + d.cluster_moved[entries[k0 + k].j_cluster()];
      }
      for (int t = 0; t < m; ++t) {
        const NeighborList::Entry& entry = entries[look[t]];
        keep(h, look[t], entry, entry_inside_bits(d, positions, entry, range2));
      }
    }
    half_done(h);
  }
}

template <class Real>
void mask_halves(const PairPositionsOf<Real>& d, int h0, int h1, std::uint32_t* inside_masks) {
  // Without nearest distances every entry is looked at, and written below.
  if (d.half_nearest) std::fill(inside_masks + d.half_start[h0], inside_masks + d.half_start[h1], 0u);
  inside_bits_of_halves(
      d, h0, h1,
      [&](int h, int k, const NeighborList::Entry&, std::uint32_t bits) { inside_masks[d.half_start[h] + k] = bits; },
      [](int) {});
}

template <class Real>
int narrow_halves(const PairPositionsOf<Real>& d, int h0, int h1, NeighborList::Entry* kept, int* kept_of_half) {
  int n = 0, before = 0;
  // Without a branch (which entries stay is unpredictable): every entry looked at is written, and
  // the next one overwrites it unless it stays.
  inside_bits_of_halves(
      d, h0, h1,
      [&](int, int, const NeighborList::Entry& entry, std::uint32_t bits) {
        kept[n] = entry;
        kept[n].mask = bits;
        n += bits != 0;
      },
      [&](int h) {
        kept_of_half[h - h0] = n - before;
        before = n;
      });
  return n;
}

}  // namespace
}  // namespace HWY_NAMESPACE
}  // namespace vimd
HWY_AFTER_NAMESPACE();

#endif  // VIMD_FORCEFIELDS_NONBONDED_PRUNING_INL_H_
