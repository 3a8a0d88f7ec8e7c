#include "forcefields/fft_grid.hpp"

#include <algorithm>
#include <mutex>
#include <new>
#include <stdexcept>

namespace vimd {

namespace {

// FFTW's planner is global; the plan lists of the grids are guarded by the same lock.
std::mutex& planner_lock() {
  static std::mutex lock;
  return lock;
}

}  // namespace

template <class T>
FftwBuffer<T>::FftwBuffer(std::size_t n) {
  // FFTW's malloc of either precision gives the same alignment; the double one serves both.
  T* p = static_cast<T*>(fftw_malloc(n * sizeof(T)));
  if (p == nullptr) throw std::bad_alloc();
  data_.reset(p);
}

template <class T>
void FftwBuffer<T>::Free::operator()(T* p) const {
  fftw_free(p);
}

template <class Real>
FftGrid<Real>::FftGrid(const std::array<int, 3>& n, int row)
    : n_(n),
      row_(row),
      real_(std::size_t(n[0]) * n[1] * row),
      complex_(std::size_t(n[0]) * n[1] * (n[2] / 2 + 1)) {
  // The row padding past nz is read (with zero weights) but never written by the transforms.
  std::fill(real(), real() + std::size_t(n[0]) * n[1] * row, Real(0));
}

template <class Real>
FftGrid<Real>::~FftGrid() {
  std::lock_guard<std::mutex> guard(planner_lock());  // destroying a plan touches the planner too
  for (const auto& count : plans_)
    for (const ThreadPlans& p : count->of_thread)
      for (auto plan : {p.forward_planes, p.forward_columns, p.backward_columns, p.backward_planes})
        if (plan != nullptr) Api::destroy(plan);
}

template <class Real>
const typename FftGrid<Real>::ThreadCountPlans& FftGrid<Real>::plan_set(int nt) {
  std::lock_guard<std::mutex> guard(planner_lock());
  for (const auto& count : plans_)
    if (count->threads == nt) return *count;
  auto count = std::make_unique<ThreadCountPlans>(ThreadCountPlans{nt, std::vector<ThreadPlans>(nt)});
  const int ny = n_[1], nzc = complex_row();
  const int plane_n[2] = {ny, n_[2]}, real_embed[2] = {ny, row_}, complex_embed[2] = {ny, nzc};
  const int real_plane = ny * row_, complex_plane = ny * nzc;
  bool planned = true;
  for (int k = 0; k < nt; ++k) {
    ThreadPlans& p = count->of_thread[k];
    // ESTIMATE plans leave the arrays alone while planning.
    if (const Share x = planes(k, nt); x.end > x.begin) {
      Real* in = real() + std::size_t(x.begin) * real_plane;
      auto* out = complex_.data() + std::size_t(x.begin) * complex_plane;
      p.forward_planes = Api::plan_r2c(2, plane_n, x.end - x.begin, in, real_embed, real_plane, out, complex_embed, complex_plane);
      p.backward_planes = Api::plan_c2r(2, plane_n, x.end - x.begin, out, complex_embed, complex_plane, in, real_embed, real_plane);
      planned = planned && p.forward_planes != nullptr && p.backward_planes != nullptr;
    }
    if (const Share y = rows(k, nt); y.end > y.begin) {
      auto* first = complex_.data() + std::size_t(y.begin) * nzc;
      const int columns = (y.end - y.begin) * nzc;
      p.forward_columns = Api::plan_c2c(n_[0], columns, first, complex_plane, FFTW_FORWARD);
      p.backward_columns = Api::plan_c2c(n_[0], columns, first, complex_plane, FFTW_BACKWARD);
      planned = planned && p.forward_columns != nullptr && p.backward_columns != nullptr;
    }
  }
  plans_.push_back(std::move(count));
  if (!planned) throw std::runtime_error("FFTW could not plan the Ewald mesh's transforms");
  return *plans_.back();
}

template class FftGrid<double>;
template class FftGrid<float>;

}  // namespace vimd
