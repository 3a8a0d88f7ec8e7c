#include "forcefields/fft_grid.hpp"

#include <algorithm>
#include <mutex>
#include <new>
#include <stdexcept>

namespace vimd {

namespace {

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
  for (const Plans& p : plans_) {
    Api::destroy(p.forward);
    Api::destroy(p.backward);
  }
}

template <class Real>
const typename FftGrid<Real>::Plans& FftGrid<Real>::plans(int threads) {
  for (const Plans& p : plans_)
    if (p.threads == threads) return p;
  std::lock_guard<std::mutex> guard(planner_lock());
  static std::once_flag threads_ready;
  std::call_once(threads_ready, [] { Api::init_threads(); });
  Api::plan_with_threads(threads);
  const int real_embed[3] = {n_[0], n_[1], row_}, complex_embed[3] = {n_[0], n_[1], complex_row()};
  // ESTIMATE plans leave the arrays alone while planning.
  Plans p{threads, Api::plan_r2c(n_.data(), real(), real_embed, complex_.data(), complex_embed),
          Api::plan_c2r(n_.data(), complex_.data(), complex_embed, real(), real_embed)};
  if (p.forward == nullptr || p.backward == nullptr) throw std::runtime_error("FFTW could not plan the Ewald mesh's transforms");
  plans_.push_back(p);
  return plans_.back();
}

template <class Real>
void FftGrid<Real>::forward(int threads) {
  Api::r2c(plans(threads).forward, real(), complex_.data());
}

template <class Real>
void FftGrid<Real>::backward(int threads) {
  Api::c2r(plans(threads).backward, complex_.data(), real());
}

template class FftGrid<double>;
template class FftGrid<float>;

}  // namespace vimd
