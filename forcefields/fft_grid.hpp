#pragma once
// FFTW 3's real-to-complex and complex-to-real transforms of a three-dimensional grid in double or
// float, for the Ewald mesh, split among the threads of a parallel region as GROMACS's fft5d splits
// them: thread t of nt transforms its share of x planes in y and z (two-dimensional transforms),
// and, after a barrier, its share of the columns along x (the complex points with y in its share
// of rows). One parallel region then holds a whole convolution with three barriers, and every plan
// runs on the thread that calls it: FFTW's own threads would start a parallel region per stage.
// The real grid is nx × ny × nz stored with rows of `row` ≥ nz reals (room for the B-splines'
// wrap-around), the complex grid nx × ny × (nz/2 + 1). Plans are FFTW_ESTIMATE (no timing: the
// same plans, hence the same results, every run), made per thread count under one lock: FFTW's
// planner is not thread-safe.
#include <fftw3.h>

#include <array>
#include <complex>
#include <cstddef>
#include <memory>
#include <vector>

#include "engine/types.hpp"

namespace vimd {

template <class Real>
struct FftwApi;

template <>
struct FftwApi<double> {
  using Plan = fftw_plan;
  using Complex = fftw_complex;
  static void destroy(Plan p) { fftw_destroy_plan(p); }
  static void execute(Plan p) { fftw_execute(p); }
  static Plan plan_r2c(int rank, const int* n, int howmany, double* in, const int* in_embed, int in_dist, Complex* out,
                       const int* out_embed, int out_dist) {
    return fftw_plan_many_dft_r2c(rank, n, howmany, in, in_embed, 1, in_dist, out, out_embed, 1, out_dist, FFTW_ESTIMATE);
  }
  static Plan plan_c2r(int rank, const int* n, int howmany, Complex* in, const int* in_embed, int in_dist, double* out,
                       const int* out_embed, int out_dist) {
    return fftw_plan_many_dft_c2r(rank, n, howmany, in, in_embed, 1, in_dist, out, out_embed, 1, out_dist, FFTW_ESTIMATE);
  }
  static Plan plan_c2c(int n, int howmany, Complex* data, int stride, int sign) {
    return fftw_plan_many_dft(1, &n, howmany, data, nullptr, stride, 1, data, nullptr, stride, 1, sign, FFTW_ESTIMATE);
  }
};

template <>
struct FftwApi<float> {
  using Plan = fftwf_plan;
  using Complex = fftwf_complex;
  static void destroy(Plan p) { fftwf_destroy_plan(p); }
  static void execute(Plan p) { fftwf_execute(p); }
  static Plan plan_r2c(int rank, const int* n, int howmany, float* in, const int* in_embed, int in_dist, Complex* out,
                       const int* out_embed, int out_dist) {
    return fftwf_plan_many_dft_r2c(rank, n, howmany, in, in_embed, 1, in_dist, out, out_embed, 1, out_dist,
                                   FFTW_ESTIMATE);
  }
  static Plan plan_c2r(int rank, const int* n, int howmany, Complex* in, const int* in_embed, int in_dist, float* out,
                       const int* out_embed, int out_dist) {
    return fftwf_plan_many_dft_c2r(rank, n, howmany, in, in_embed, 1, in_dist, out, out_embed, 1, out_dist,
                                   FFTW_ESTIMATE);
  }
  static Plan plan_c2c(int n, int howmany, Complex* data, int stride, int sign) {
    return fftwf_plan_many_dft(1, &n, howmany, data, nullptr, stride, 1, data, nullptr, stride, 1, sign, FFTW_ESTIMATE);
  }
};

// Memory aligned as FFTW's SIMD codelets want it.
template <class T>
class FftwBuffer {
 public:
  FftwBuffer() = default;
  explicit FftwBuffer(std::size_t n);
  T* data() { return data_.get(); }
  const T* data() const { return data_.get(); }

 private:
  struct Free {
    void operator()(T* p) const;
  };
  std::unique_ptr<T[], Free> data_;
};

// [begin, end): thread t's share of n items among nt threads, in order (share_begin's split, so
// that share_owners agrees with it).
struct Share {
  int begin, end;
};
inline Share share_of(int n, int t, int nt) { return {share_begin(n, t, nt), share_begin(n, t + 1, nt)}; }

// A real grid and its transform. Every thread of a parallel region calls each step in turn, with
// a barrier wherever the next step reads another thread's share:
//   forward_planes | forward_columns, (work on the thread's columns), backward_columns | backward_planes
// Transforms are unnormalised; forward is e^{−2πi k·g/n}, backward e^{+2πi k·g/n} and destroys the
// complex grid.
template <class Real>
class FftGrid {
 public:
  using Complex = std::complex<Real>;  // layout-compatible with FFTW's

  FftGrid(const std::array<int, 3>& n, int row);
  ~FftGrid();
  FftGrid(const FftGrid&) = delete;
  FftGrid& operator=(const FftGrid&) = delete;

  Real* real() { return real_.data(); }
  const Real* real() const { return real_.data(); }
  Complex* complex() { return reinterpret_cast<Complex*>(complex_.data()); }
  int row() const { return row_; }
  int complex_row() const { return n_[2] / 2 + 1; }

  Share planes(int t, int nt) const { return share_of(n_[0], t, nt); }  // x
  Share rows(int t, int nt) const { return share_of(n_[1], t, nt); }    // y: the thread's columns

  // Makes (or finds) the plans for nt threads and makes them the current ones; called outside the
  // parallel region, where a failure can be thrown and where taking the planner's lock costs the
  // steps nothing. A step of another thread count (a nested region) looks its plans up under the lock.
  void prepare(int nt) { current_ = &plan_set(nt); }
  void forward_planes(int t, int nt) { execute(plans(t, nt).forward_planes); }
  void forward_columns(int t, int nt) { execute(plans(t, nt).forward_columns); }
  void backward_columns(int t, int nt) { execute(plans(t, nt).backward_columns); }
  void backward_planes(int t, int nt) { execute(plans(t, nt).backward_planes); }

 private:
  using Api = FftwApi<Real>;
  // One thread's plans (null where its share is empty: nothing to execute).
  struct ThreadPlans {
    typename Api::Plan forward_planes = nullptr, forward_columns = nullptr, backward_columns = nullptr,
                       backward_planes = nullptr;
  };
  struct ThreadCountPlans {
    int threads;
    std::vector<ThreadPlans> of_thread;
  };
  static void execute(typename Api::Plan p) {
    if (p != nullptr) Api::execute(p);
  }
  const ThreadCountPlans& plan_set(int nt);  // under the planner's lock
  const ThreadPlans& plans(int t, int nt) {
    return current_ != nullptr && current_->threads == nt ? current_->of_thread[t] : plan_set(nt).of_thread[t];
  }

  std::array<int, 3> n_;
  int row_;
  FftwBuffer<Real> real_;
  FftwBuffer<typename Api::Complex> complex_;
  std::vector<std::unique_ptr<ThreadCountPlans>> plans_;  // per thread count met; stable while threads read them
  const ThreadCountPlans* current_ = nullptr;              // the last prepared
};

}  // namespace vimd
