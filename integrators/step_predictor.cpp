#include "integrators/step_predictor.hpp"

#include <algorithm>
#include <stdexcept>
#include <string>

#include "integrators/coords_ops.hpp"

namespace vimd {

StepPredictor::StepPredictor(int atoms, int history) : history_(history) {
  auto zero = [atoms](Offsets& o) {
    for (Coords* c : {&o.q, &o.v, &o.p}) c->setZero(3, atoms);
  };
  for (Offsets& o : recorded_) zero(o);
  zero(predicted_);
  q_standard_.setZero(3, atoms);
  v_standard_.setZero(3, atoms);
}

bool StepPredictor::corrects() const { return recorded_count_ > 0 && history_ > 0; }

double StepPredictor::newest_offset_size(double h) const {
  if (recorded_count_ == 0) return 0;
  return std::max(max_abs(recorded_[0].v), max_abs(recorded_[0].q) / h);
}

// A polynomial through the last offsets predicts the next one a little better than the last alone:
// they change by most of their size from step to step (at the pace of the fastest motion), yet the
// extrapolation still lowers the first residual of a step enough to spare many steps an iteration.
void StepPredictor::begin_step(const Coords& q_standard, const Coords& v_standard) {
  parallel_assign(q_standard_, q_standard);
  parallel_assign(v_standard_, v_standard);
  static constexpr double kWeights[kMaxHistory][kMaxHistory] = {{1, 0, 0}, {2, -1, 0}, {3, -3, 1}};
  const int used = std::min(recorded_count_, history_);
  if (used == 0) {
    for (Coords* c : {&predicted_.q, &predicted_.v, &predicted_.p}) c->setZero();
    return;
  }
  const double* c = kWeights[used - 1];
  const auto& o = recorded_;
  for_each_atom(static_cast<int>(q_standard.cols()), [&](int i) {
    predicted_.q.col(i) = c[0] * o[0].q.col(i);
    predicted_.v.col(i) = c[0] * o[0].v.col(i);
    predicted_.p.col(i) = c[0] * o[0].p.col(i);
    for (int k = 1; k < used; ++k) {
      predicted_.q.col(i) += c[k] * o[k].q.col(i);
      predicted_.v.col(i) += c[k] * o[k].v.col(i);
      predicted_.p.col(i) += c[k] * o[k].p.col(i);
    }
  });
}

StepPredictor::Offsets& StepPredictor::push(const Coords& pbar, const Coords& plus_segment_momentum) {
  std::rotate(recorded_.rbegin(), recorded_.rbegin() + 1, recorded_.rend());  // swaps storage, copies nothing
  recorded_count_ = std::min(recorded_count_ + 1, kMaxHistory);
  Offsets& newest = recorded_[0];
  parallel_assign(newest.p, pbar - plus_segment_momentum);
  return newest;
}

void StepPredictor::record(const Coords& q, const Coords& v, const Coords& pbar,
                           const Coords& plus_segment_momentum) {
  Offsets& newest = push(pbar, plus_segment_momentum);
  parallel_assign(newest.q, q - q_standard_);
  parallel_assign(newest.v, v - v_standard_);
}

void StepPredictor::record_momentum(const Coords& pbar, const Coords& plus_segment_momentum) {
  Offsets& newest = push(pbar, plus_segment_momentum);
  newest.q.setZero();
  newest.v.setZero();
}

void StepPredictor::save(Carried& out) const {
  for (int k = 0; k < recorded_count_; ++k) {
    const std::string age = std::to_string(k);
    out.put("q_offset_" + age, recorded_[k].q);
    out.put("v_offset_" + age, recorded_[k].v);
    out.put("p_offset_" + age, recorded_[k].p);
  }
  out.put("offsets_recorded", recorded_count_);
}

void StepPredictor::restore(const Carried& in) {
  const Eigen::Index n = q_standard_.cols();
  auto take = [&](const std::string& name, Coords& into) {
    Coords value = in.coords(name);
    if (value.cols() != n) throw std::invalid_argument("StepPredictor::restore: " + name);
    into = std::move(value);
  };
  const double count = in.number("offsets_recorded");
  if (!(count >= 0 && count <= kMaxHistory)) throw std::invalid_argument("StepPredictor::restore: offsets_recorded");
  recorded_count_ = static_cast<int>(count);
  for (int k = 0; k < recorded_count_; ++k) {
    const std::string age = std::to_string(k);
    take("q_offset_" + age, recorded_[k].q);
    take("v_offset_" + age, recorded_[k].v);
    take("p_offset_" + age, recorded_[k].p);
  }
}

}  // namespace vimd
