#pragma once
// Anderson mixing for a fixed-point iteration x ← T(x). With f = T(x) − x and Δ·_j = ·_k − ·_{k−j}
// over the last m iterates,
//   x_{k+1} = x_k + f_k − Σ_j γ_j (Δx_j + Δf_j),   γ = argmin ‖f_k − Σ_j γ_j Δf_j‖₂.
// A vector is n blocks of Rows entries (the columns of a Rows × n matrix), each block's share of an
// inner product summed first, the blocks in parallel. What the entries mean is the caller's
// business; it scales them so that they are comparable in the 2-norm.
#include <algorithm>
#include <limits>
#include <vector>

#include <Eigen/Dense>

#include "integrators/coords_ops.hpp"

namespace vimd {

constexpr int kMaxAndersonDepth = 8;

template <int Rows>
class AndersonMixer {
 public:
  using Vector = Eigen::Matrix<double, Rows, Eigen::Dynamic>;
  using Block = Eigen::Matrix<double, Rows, 1>;

  // Mixes over up to `depth` (1..kMaxAndersonDepth) differences, on vectors of `blocks` blocks.
  AndersonMixer(int depth, int blocks) : x_(depth + 1, Vector(Rows, blocks)), f_(x_) {}

  // Forgets the iterates so far: a new solve, or the iteration was damped.
  void restart() { count_ = 0; }

  // Adds the iterate x_k and its residual f_k = T(x_k) − x_k: fill(i, x_i, f_i) writes their block i.
  template <class Fill>
  void record(Fill&& fill) {
    ++count_;
    newest_ = (count_ - 1) % slots();
    Vector& x = x_[newest_];
    Vector& f = f_[newest_];
    parallel_for(blocks(), [&](int i) { fill(i, x.col(i), f.col(i)); });
  }

  // x_{k+1} from the iterates recorded since the last restart (x_k + f_k after the first);
  // take(i, x_i) receives its block i.
  template <class Take>
  void mix(Take&& take) const {
    const Vector& xk = x_[newest_];
    const Vector& fk = f_[newest_];
    const int n = blocks();
    const int m = std::min(count_, slots()) - 1;
    Eigen::Matrix<double, kMaxAndersonDepth, 1> gamma = Eigen::Matrix<double, kMaxAndersonDepth, 1>::Zero();
    if (m > 0) {
      // Normal equations of the least-squares problem: (Δf_a·Δf_b) γ = Δf_a·f_k.
      Eigen::Matrix<double, kMaxAndersonDepth, kMaxAndersonDepth> gram;
      Eigen::Matrix<double, kMaxAndersonDepth, 1> rhs;
      for (int a = 1; a <= m; ++a) {
        const Vector& fa = f_[older(a)];
        for (int b = a; b <= m; ++b) {
          const Vector& fb = f_[older(b)];
          gram(a - 1, b - 1) = gram(b - 1, a - 1) =
              parallel_sum(n, [&](int i) { return (fk.col(i) - fa.col(i)).dot(fk.col(i) - fb.col(i)); });
        }
        rhs(a - 1) = parallel_sum(n, [&](int i) { return (fk.col(i) - fa.col(i)).dot(fk.col(i)); });
      }
      // Regularised: the differences can be nearly dependent (m ≤ kMaxAndersonDepth, a tiny system).
      Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, kMaxAndersonDepth, kMaxAndersonDepth> a =
          gram.topLeftCorner(m, m);
      a.diagonal().array() += 1e-10 * a.trace() + std::numeric_limits<double>::min();
      gamma.head(m) = a.ldlt().solve(rhs.head(m));
    }
    parallel_for(n, [&](int i) {
      Block x = xk.col(i) + fk.col(i);
      for (int j = 1; j <= m; ++j)
        x -= gamma(j - 1) * (xk.col(i) - x_[older(j)].col(i) + fk.col(i) - f_[older(j)].col(i));
      take(i, x);
    });
  }

 private:
  int slots() const { return static_cast<int>(x_.size()); }
  int blocks() const { return static_cast<int>(x_[0].cols()); }
  // The slot of the iterate j before the newest.
  int older(int j) const { return ((newest_ - j) % slots() + slots()) % slots(); }

  std::vector<Vector> x_, f_;  // ring of the last depth + 1 iterates and residuals
  int count_ = 0;              // iterates recorded since the last restart
  int newest_ = 0;
};

}  // namespace vimd
