// How SIMD vectors cover the cluster pairs of the neighbour list (neighbor_list.hpp), shared by the
// search's distance test (cluster_pair_kernels.cpp) and the pair loops (forcefields/). A Highway
// per-target header: see simd/simd-inl.h.
#if defined(VIMD_FORCEFIELDS_NONBONDED_PAIR_LAYOUT_INL_H_) == defined(HWY_TARGET_TOGGLE)
#ifdef VIMD_FORCEFIELDS_NONBONDED_PAIR_LAYOUT_INL_H_
#undef VIMD_FORCEFIELDS_NONBONDED_PAIR_LAYOUT_INL_H_
#else
#define VIMD_FORCEFIELDS_NONBONDED_PAIR_LAYOUT_INL_H_
#endif

#include <type_traits>

#include "forcefields/nonbonded/neighbor_list.hpp"
#include "simd/simd-inl.h"

HWY_BEFORE_NAMESPACE();
namespace vimd {
namespace HWY_NAMESPACE {

constexpr int kC = NeighborList::kClusterSize;
constexpr int kH = NeighborList::kHalfSize;

// A vector holds kJLanes j atoms for each of kRows consecutive i atoms (rows). One row where a
// vector is at most a j-cluster wide; two where it is twice as wide (16 floats on AVX-512,
// GROMACS's 2xMM layout), so that every target fills its vectors.
template <class Real>
struct PairLayout {
  using Tag = typename SimdVec<Real>::Tag;
  static constexpr int kLanes = static_cast<int>(hn::MaxLanes(Tag()));
  static constexpr int kRows = kLanes > NeighborList::kClusterSize ? kLanes / NeighborList::kClusterSize : 1;
  static constexpr int kJLanes = kLanes / kRows;
  static constexpr int kRowVectors = NeighborList::kHalfSize / kRows;  // vectors per half-cluster
  static_assert(kRows <= 2 && NeighborList::kHalfSize % kRows == 0);
};

// The two-row branches call Combine, LowerHalf and UpperHalf unqualified: found by argument-dependent
// lookup in the targets that have them (the portable scalar target has not, and has one row).

// The kJLanes values at p, the same for every row.
template <class Real>
HWY_INLINE SimdVec<Real> load_j(const Real* p) {
  using L = PairLayout<Real>;
  if constexpr (L::kRows == 1) {
    return simd_load(p);
  } else {
#if HWY_ARCH_X86 && HWY_TARGET <= HWY_AVX3
    // One broadcasting load; Combine's load and insert would take a shuffle port the FMAs need.
    if constexpr (std::is_same_v<Real, float>)
      return {hn::Vec<typename L::Tag>{_mm512_broadcast_f32x8(_mm256_loadu_ps(p))}};
#endif
    const hn::Half<typename L::Tag> half;
    const auto j = hn::LoadU(half, p);
    return {Combine(typename L::Tag(), j, j)};
  }
}
// Row r of the vector: values[ii + r], on all of its lanes.
template <class Real>
HWY_INLINE SimdVec<Real> broadcast_rows(const Real* values, int ii) {
  using L = PairLayout<Real>;
  if constexpr (L::kRows == 1) {
    return SimdVec<Real>::broadcast(values[ii]);
  } else {
    const hn::Half<typename L::Tag> half;
    return {Combine(typename L::Tag(), hn::Set(half, values[ii + 1]), hn::Set(half, values[ii]))};
  }
}

// The pairs an entry's mask lists (bit ii·kC + j for the pair of row ii and j atom j), per vector
// of (row ii, j offset js): as scalar bits (to skip a vector with none) and as a vector mask. With
// mask registers (AVX-512) the vector mask is the scalar bits moved in. Without (AVX2 and
// narrower) building it from scalar bits takes a move, a broadcast, an and and a compare per
// vector; instead the mask is broadcast once per entry and each vector's lanes are one test against
// that vector's lane bits. The lane bits are held, not computed at each use: where the j offsets
// are a run-time loop they would be assembled by scalar stores that the vector load cannot forward
// from.
template <class Real>
class ListedLanes {
  using L = PairLayout<Real>;
  using Mask = SimdMaskOf<Real>;
  static constexpr int kC = NeighborList::kClusterSize;

 public:
  // The entry's bits of the vector of row ii and j offset js (0: no pair of it is listed).
  HWY_INLINE unsigned bits(int ii, int js) const { return (mask_ >> (ii * kC + js)) & ((1u << L::kLanes) - 1); }
#if HWY_ARCH_X86 && HWY_TARGET <= HWY_AVX3
  HWY_INLINE void start(std::uint32_t mask) { mask_ = mask; }
  HWY_INLINE Mask of(int ii, int js) const { return mask_from_bits<Real>(bits(ii, js)); }

 private:
  std::uint32_t mask_ = 0;
#else
  HWY_INLINE ListedLanes() {
    const Unsigned du;
    for (int r = 0; r < L::kRowVectors; ++r)
      for (int b = 0; b < kJBlocks; ++b)
        bit_[r][b] = hn::Shl(hn::Set(du, 1), hn::Iota(du, r * L::kRows * kC + b * L::kJLanes));
  }
  HWY_INLINE void start(std::uint32_t mask) {
    mask_ = mask;
    broadcast_ = hn::Set(Unsigned(), mask);
  }
  HWY_INLINE Mask of(int ii, int js) const {
    return {hn::RebindMask(typename L::Tag(), hn::TestBit(broadcast_, bit_[ii / L::kRows][js / L::kJLanes]))};
  }

 private:
  using Unsigned = hn::RebindToUnsigned<typename L::Tag>;
  static constexpr int kJBlocks = kC / L::kJLanes;
  std::uint32_t mask_ = 0;
  hn::Vec<Unsigned> bit_[L::kRowVectors][kJBlocks];
  hn::Vec<Unsigned> broadcast_;
#endif
};

// The i-half's positions, per vector of rows, moved by −s for the run of its entries with shift s
// (a half's entries come by shift): x_i − (x_j + s) as (x_i − s) − x_j, the shift applied once per
// run, to positions read again from the slot arrays (no unshifted copies held in registers).
template <class Real>
struct ShiftedHalf {
  static constexpr int kVectors = PairLayout<Real>::kRowVectors;
  SimdVec<Real> x[kVectors], y[kVectors], z[kVectors];
  int shift = -1, ib = 0;

  HWY_INLINE void start(int h) {
    ib = h * kH;
    shift = -1;
  }
  template <class Positions>  // PairPositionsOf<Real>
  HWY_INLINE void follow(const Positions& d, int s) {
    if (s == shift) return;
    shift = s;
    const Vec3& by = d.shifts[s];
    for (int r = 0; r < kVectors; ++r) {
      x[r] = broadcast_rows(d.x + ib, r * PairLayout<Real>::kRows) - by[0];
      y[r] = broadcast_rows(d.y + ib, r * PairLayout<Real>::kRows) - by[1];
      z[r] = broadcast_rows(d.z + ib, r * PairLayout<Real>::kRows) - by[2];
    }
  }
};

}  // namespace HWY_NAMESPACE
}  // namespace vimd
HWY_AFTER_NAMESPACE();

#endif  // VIMD_FORCEFIELDS_NONBONDED_PAIR_LAYOUT_INL_H_
