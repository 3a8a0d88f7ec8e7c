#pragma once
// The first guess of a variational step's solution (q, v, p⁺). The standard layer's step Φ_h(w_k)
// for (q, v) and Π(M·V⁺) for p⁺ differ from the solution by a smooth O(h^{p+1}) amount, the offset;
// this class keeps the last steps' offsets and extrapolates them by a polynomial to correct the
// next guess.
#include <array>

#include "engine/carried.hpp"
#include "engine/types.hpp"

namespace vimd {

class StepPredictor {
 public:
  static constexpr int kMaxHistory = 3;

  // `history`: how many past offsets the extrapolation uses (0: none, 1: the last one, 2: linear,
  // 3: quadratic).
  StepPredictor(int atoms, int history);

  // A new step whose standard-layer guess is (q_standard, v_standard): extrapolates the offsets.
  void begin_step(const Coords& q_standard, const Coords& v_standard);
  // Whether the extrapolated offsets correct the guess (false: no offsets recorded or used; the
  // offsets below are then zero).
  bool corrects() const;
  const Coords& q_offset() const { return predicted_.q; }
  const Coords& v_offset() const { return predicted_.v; }
  const Coords& p_offset() const { return predicted_.p; }
  // The newest recorded offset of (q, v), max(‖δv‖∞, ‖δq‖∞/h) in nm/ps like the solver's residual:
  // the scale of the method's local truncation error; 0 before the first step's offset.
  double newest_offset_size(double h) const;

  // Records the accepted point: q and v against this step's standard guess, and p̄ against
  // Π(M·V⁺), both tangent at q̄ = ∂⁺(w) (the normal part would be rotated into the tangent space at
  // the next ∂⁺ and spoil the prediction).
  void record(const Coords& q, const Coords& v, const Coords& pbar, const Coords& plus_segment_momentum);
  // The same at the initialisation, which has no guess of (q, v): their offsets are zero.
  void record_momentum(const Coords& pbar, const Coords& plus_segment_momentum);

  // Checkpoints: the recorded offsets.
  void save(Carried& out) const;
  // std::invalid_argument when an entry is missing, of the wrong size or out of range.
  void restore(const Carried& in);

 private:
  struct Offsets {
    Coords q, v, p;
  };
  // Shifts the history by one and sets the newest momentum offset p̄ − Π(M·V⁺).
  Offsets& push(const Coords& pbar, const Coords& plus_segment_momentum);

  int history_;
  std::array<Offsets, kMaxHistory> recorded_;  // newest first
  int recorded_count_ = 0;
  Offsets predicted_;
  Coords q_standard_, v_standard_;
};

}  // namespace vimd
