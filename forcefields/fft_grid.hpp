#pragma once
// FFTW 3's three-dimensional real-to-complex and complex-to-real transforms in double or float,
// for the Ewald mesh. The real grid is nx × ny × nz stored with rows of `row` ≥ nz reals (room for
// the B-splines' wrap-around), the complex grid nx × ny × (nz/2 + 1). Plans are FFTW_ESTIMATE (no
// timing: the same plan, hence the same results, every run), made once per thread count, and made
// under one lock: FFTW's planner is not thread-safe.
#include <fftw3.h>

#include <array>
#include <complex>
#include <cstddef>
#include <memory>
#include <vector>

namespace vimd {

template <class Real>
struct FftwApi;

template <>
struct FftwApi<double> {
  using Plan = fftw_plan;
  using Complex = fftw_complex;
  static void destroy(Plan p) { fftw_destroy_plan(p); }
  static void init_threads() { fftw_init_threads(); }
  static void plan_with_threads(int n) { fftw_plan_with_nthreads(n); }
  static Plan plan_r2c(const int* n, double* in, const int* in_embed, Complex* out, const int* out_embed) {
    return fftw_plan_many_dft_r2c(3, n, 1, in, in_embed, 1, 0, out, out_embed, 1, 0, FFTW_ESTIMATE);
  }
  static Plan plan_c2r(const int* n, Complex* in, const int* in_embed, double* out, const int* out_embed) {
    return fftw_plan_many_dft_c2r(3, n, 1, in, in_embed, 1, 0, out, out_embed, 1, 0, FFTW_ESTIMATE);
  }
  static void r2c(Plan p, double* in, Complex* out) { fftw_execute_dft_r2c(p, in, out); }
  static void c2r(Plan p, Complex* in, double* out) { fftw_execute_dft_c2r(p, in, out); }
};

template <>
struct FftwApi<float> {
  using Plan = fftwf_plan;
  using Complex = fftwf_complex;
  static void destroy(Plan p) { fftwf_destroy_plan(p); }
  static void init_threads() { fftwf_init_threads(); }
  static void plan_with_threads(int n) { fftwf_plan_with_nthreads(n); }
  static Plan plan_r2c(const int* n, float* in, const int* in_embed, Complex* out, const int* out_embed) {
    return fftwf_plan_many_dft_r2c(3, n, 1, in, in_embed, 1, 0, out, out_embed, 1, 0, FFTW_ESTIMATE);
  }
  static Plan plan_c2r(const int* n, Complex* in, const int* in_embed, float* out, const int* out_embed) {
    return fftwf_plan_many_dft_c2r(3, n, 1, in, in_embed, 1, 0, out, out_embed, 1, 0, FFTW_ESTIMATE);
  }
  static void r2c(Plan p, float* in, Complex* out) { fftwf_execute_dft_r2c(p, in, out); }
  static void c2r(Plan p, Complex* in, float* out) { fftwf_execute_dft_c2r(p, in, out); }
};

// Memory aligned as FFTW's SIMD codelets want it: every buffer of a plan's kind alike, so one plan
// serves all of them (new-array execution).
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

// A real grid and its transform; forward() and backward() execute the plans for a thread count
// (planned at its first use).
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

  void forward(int threads);   // real → complex (unnormalised, e^{−2πi k·g/n})
  void backward(int threads);  // complex → real (unnormalised, e^{+2πi k·g/n}); the complex grid is destroyed

 private:
  using Api = FftwApi<Real>;
  struct Plans {
    int threads;
    typename Api::Plan forward, backward;
  };
  const Plans& plans(int threads);

  std::array<int, 3> n_;
  int row_;
  FftwBuffer<Real> real_;
  FftwBuffer<typename Api::Complex> complex_;
  std::vector<Plans> plans_;  // per thread count met
};

}  // namespace vimd
