#include "forcefields/ewald_mesh.hpp"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <utility>

#include "engine/types.hpp"
#include "forcefields/bspline.hpp"
#include "forcefields/ewald_mesh_kernels.hpp"
#include "forcefields/fft_grid.hpp"
#include "forcefields/settings.hpp"

namespace vimd {

namespace {

// |Σ_{j=1}^{p−1} M_p(j) e^{2πi k j/n}|² for k = 0..n−1: the B(k) of the influence function, as
// GROMACS computes it (make_bspline_moduli). For odd p and even n it vanishes at k = n/2; GROMACS
// then takes the mean of its neighbours there (Essmann et al.: that term's weight is negligible).
std::vector<double> bspline_moduli(int n, int p) {
  const auto m = spline_at_integers(p);
  std::vector<double> b(n);
  for (int k = 0; k < n; ++k) {
    double c = 0, s = 0;
    for (int j = 1; j < p; ++j) {
      const double arg = 2 * M_PI * k * j / n;
      c += m[j - 1] * std::cos(arg);
      s += m[j - 1] * std::sin(arg);
    }
    b[k] = c * c + s * s;
  }
  if (p % 2 == 1 && n % 2 == 0) b[n / 2] = 0.5 * (b[n / 2 - 1] + b[n / 2 + 1]);
  return b;
}

// Rows of an odd length put every other row of the real grid off FFTW's SIMD alignment: its
// transforms then take about a fifth longer.
int even_row(int length) { return length + length % 2; }

}  // namespace

double ewald_mesh_bytes(const std::array<double, 3>& n, int order, bool single_precision, int threads) {
  const double row = n[2] + spline_stride(order) - 1 + 1;  // even_row's bound
  const double half_complex = n[0] * n[1] * (std::floor(n[2] / 2) + 1);
  const double real = single_precision ? sizeof(float) : sizeof(double);
  const double transform_grid = real * (n[0] * n[1] * row + 2 * half_complex);
  const double spreading = real * (n[0] + double(threads) * (order - 1)) * n[1] * row;
  return sizeof(double) * half_complex + 2 * transform_grid + spreading;
}

namespace {

// GROMACS's aliasing sums for one direction (gmx_pme_error.cpp: eps_poly1..4 and eps_self), for
// the wave numbers m = −⌊K/2⌋..⌊K/2⌋ of a grid of K points and order p: with t_i = 2π (m/K + i),
// S_k = Σ_{0<|i|≤6} t_i^(−k) and D = Σ_{|i|≤6} t_i^(−p),
//   e1 = −S_p / D,  e2 = S_2p / D² + e1²,  e3 = 2π Σ i t_i^(−2p) / D²,  e4 = 4π² Σ i² t_i^(−2p) / D²,
// and the self force's eps_self = Σ_{i≠0} sin(2π i u) a_i with a_i = −2πK i t_i^(−p) / D at the
// charge's grid coordinate u (all 0 at m = 0). For odd p and even K, D vanishes at m = ±K/2 as the
// moduli B do there, where the mesh takes its neighbours' (bspline_moduli): so do the sums.
constexpr int kImages = 6;  // GROMACS's SUMORDER
struct AliasingSums {
  std::vector<double> e1, e2, e3, e4;
  std::vector<std::array<double, kImages>> self;  // per m: a_i − a_−i for i = 1..6 (sin is odd)
};
AliasingSums aliasing_sums(int k_points, int p) {
  const int half = k_points / 2;
  AliasingSums a;
  for (auto* e : {&a.e1, &a.e2, &a.e3, &a.e4}) e->assign(2 * half + 1, 0.0);
  a.self.assign(2 * half + 1, {});
  for (int m = -half; m <= half; ++m) {
    if (m == 0 || (p % 2 == 1 && 2 * std::abs(m) == k_points)) continue;  // the latter below
    double s_p = 0, s_2p = 0, s_i = 0, s_ii = 0;
    std::array<double, 2 * kImages + 1> t_p{};
    for (int i = -kImages; i <= kImages; ++i) {
      t_p[i + kImages] = std::pow(2 * M_PI * (double(m) / k_points + i), -p);
      if (i == 0) continue;
      const double t_2p = t_p[i + kImages] * t_p[i + kImages];
      s_p += t_p[i + kImages];
      s_2p += t_2p;
      s_i += i * t_2p;
      s_ii += double(i) * i * t_2p;
    }
    const double d = t_p[kImages] + s_p;
    const int k = m + half;
    a.e1[k] = -s_p / d;
    a.e2[k] = s_2p / (d * d) + a.e1[k] * a.e1[k];
    a.e3[k] = 2 * M_PI * s_i / (d * d);
    a.e4[k] = 4 * M_PI * M_PI * s_ii / (d * d);
    for (int i = 1; i <= kImages; ++i)
      a.self[k][i - 1] = -2 * M_PI * k_points * (i * t_p[kImages + i] + i * t_p[kImages - i]) / d;
  }
  if (p % 2 == 1 && k_points % 2 == 0 && half > 1) {
    for (auto* e : {&a.e1, &a.e2, &a.e3, &a.e4}) (*e)[0] = (*e)[1], (*e)[2 * half] = (*e)[2 * half - 1];
    a.self[0] = a.self[1], a.self[2 * half] = a.self[2 * half - 1];
  }
  return a;
}

}  // namespace

MeshForceError ewald_mesh_force_error(const Vec3& box, const std::array<int, 3>& n, int order, double beta,
                                      double prefactor, double sum_q2, double sum_q4, int n_charges) {
  if (n_charges == 0) return {0, 0};
  // The sums over the wave vectors approximate integrals once a direction holds many of them:
  // beyond kProxyPoints grid points, a box of that many at the same spacing gives the estimate (the
  // first two terms, ∝ 1/√V at a given Σq² and N, scaled by its volume; the third does not depend
  // on V) at a fraction of the cost, which would grow as the grid's size.
  constexpr int kProxyPoints = 64;
  if (*std::max_element(n.begin(), n.end()) > kProxyPoints) {
    std::array<int, 3> proxy_n = n;
    Vec3 proxy_box = box;
    for (int d = 0; d < 3; ++d)
      if (n[d] > kProxyPoints) proxy_n[d] = kProxyPoints, proxy_box[d] = box[d] * kProxyPoints / n[d];
    MeshForceError e = ewald_mesh_force_error(proxy_box, proxy_n, order, beta, prefactor, sum_q2, sum_q4, n_charges);
    e.pairs *= std::sqrt(proxy_box.prod() / box.prod());
    return e;
  }
  std::array<AliasingSums, 3> sums;
  std::array<int, 3> half{}, reach{};
  for (int d = 0; d < 3; ++d) {
    sums[d] = aliasing_sums(n[d], order);
    half[d] = n[d] / 2;
    // Beyond this wave number a direction's factor exp(−π² m_d²/β²) of every term is below 1e-20
    // (1e-40 squared): the rest of the sum changes nothing (and a fine grid costs no more than it needs).
    reach[d] = std::min(half[d], static_cast<int>(std::ceil(beta * box[d] * std::sqrt(20 * std::log(10.0)) / M_PI)));
  }
  const double volume = box[0] * box[1] * box[2];
  double term1 = 0, term2 = 0;  // GROMACS's e_rec1, e_rec2 without their common factor (Σq²)²/N
  std::array<std::array<double, kImages>, 3> self{};  // Σ_m e^(−π²m²/β²)/m² (a_i − a_−i) per direction
  for (int x = -reach[0]; x <= reach[0]; ++x)
    for (int y = -reach[1]; y <= reach[1]; ++y)
      for (int z = -reach[2]; z <= reach[2]; ++z) {
        if (x == 0 && y == 0 && z == 0) continue;
        const std::array<int, 3> m{x, y, z};
        Vec3 g;
        double e1[3], e2[3], e3[3], e4[3];
        for (int d = 0; d < 3; ++d) {
          g[d] = m[d] / box[d];
          const int k = m[d] + half[d];
          e1[d] = sums[d].e1[k], e2[d] = sums[d].e2[k], e3[d] = sums[d].e3[k], e4[d] = sums[d].e4[k];
        }
        const double g2 = g.squaredNorm();
        const double damping = std::exp(-M_PI * M_PI * g2 / (beta * beta)) / g2;
        const double coeff = damping / (2 * M_PI * volume);
        const double e1_sum = e1[0] + e1[1] + e1[2];
        const double t1 = e2[0] + e2[1] + e2[2] + 2 * (e1[0] * e1[1] + e1[1] * e1[2] + e1[2] * e1[0]) + e1_sum * e1_sum;
        term1 += 32 * M_PI * M_PI * coeff * coeff * g2 * t1;
        double t2 = 0;
        for (int d = 0; d < 3; ++d)
          t2 += 4 * M_PI * e3[d] * n[d] * g[d] / box[d] + e4[d] * double(n[d]) * n[d] / (box[d] * box[d]);
        term2 += 4 * coeff * coeff * t2;
        for (int d = 0; d < 3; ++d)
          for (int i = 0; i < kImages; ++i) self[d][i] += damping * sums[d].self[m[d] + half[d]][i];
      }
  // Term III, GROMACS's e_rec3 = <q⁴ |Σ_d r_d Σ_m e^(−π²m²/β²)/m² eps_self_d|²> / (π² V²), r_d the
  // reciprocal box vectors: GROMACS averages it over (a sample of) the charges' positions; here over
  // a position spread evenly in the grid cell, where <sin(2π i u) sin(2π j u)> = δ_ij / 2.
  double self_force2 = 0;
  for (int d = 0; d < 3; ++d)
    for (int i = 0; i < kImages; ++i) self_force2 += 0.5 * self[d][i] * self[d][i] / (box[d] * box[d]);
  const double term3 = sum_q4 / n_charges * self_force2 / (M_PI * M_PI * volume * volume);
  return {prefactor * std::sqrt((term1 + term2) * sum_q2 * sum_q2 / n_charges), prefactor * std::sqrt(term3)};
}

struct EwaldMeshSetup {
  std::array<int, 3> n;
  int order;
  int row;          // real-grid row length: a charge's z points (vectors of them) never wrap; even
  Vec3 scale;       // n/L: d(grid coordinate)/dx, nm⁻¹
  std::vector<double> charge;
  double net_charge_energy;
  // On the half-complex grid (x, y, kz ≤ nz/2): f/ε_r exp(−π²m²/β²) / (π V m² B(m)), 0 at m = 0,
  // and the energy weight of each kz (1 for kz = 0 and nz/2, which the half grid holds once; 2
  // for the others, which stand for ±kz).
  std::vector<double> influence;
  std::vector<double> energy_weight;

  EwaldMeshSetup(const System& system, const EwaldMeshParameters& p)
      : n(p.grid), order(p.order), row(even_row(p.grid[2] + spline_stride(p.order) - 1)), charge(system.charge.data(), system.charge.data() + system.n_atoms()) {
    if (!system.box.periodic())
      throw std::invalid_argument("the Ewald mesh (PME) needs a box periodic in x, y and z");
    if (p.order < kMinPmeOrder || p.order > kMaxPmeOrder)
      throw std::invalid_argument("PME order " + std::to_string(p.order) + " is outside " +
                                  std::to_string(kMinPmeOrder) + ".." + std::to_string(kMaxPmeOrder));
    for (int d = 0; d < 3; ++d)
      if (n[d] < p.order)
        throw std::invalid_argument("PME grid of " + std::to_string(n[d]) + " points is smaller than the order " +
                                    std::to_string(p.order));
    if (!(p.beta > 0)) throw std::invalid_argument("the Ewald coefficient beta must be positive");
    const Vec3& length = system.box.length;
    const double volume = system.box.volume();
    for (int d = 0; d < 3; ++d) scale[d] = n[d] / length[d];
    double total = 0;
    for (double q : charge) total += q;
    net_charge_energy = -M_PI * p.prefactor * total * total / (2 * volume * p.beta * p.beta);

    std::array<std::vector<double>, 3> moduli;
    for (int d = 0; d < 3; ++d) moduli[d] = bspline_moduli(n[d], p.order);
    const int nzc = n[2] / 2 + 1;
    influence.resize(std::size_t(n[0]) * n[1] * nzc);
    const double factor = M_PI * M_PI / (p.beta * p.beta);
    auto wave = [&](int k, int d) { return (k < (n[d] + 1) / 2 ? k : k - n[d]) / length[d]; };
    for (int x = 0; x < n[0]; ++x)
      for (int y = 0; y < n[1]; ++y)
        for (int z = 0; z < nzc; ++z) {
          const double mx = wave(x, 0), my = wave(y, 1), mz = z / length[2];
          const double m2 = mx * mx + my * my + mz * mz;
          const std::size_t i = (std::size_t(x) * n[1] + y) * nzc + z;
          influence[i] = m2 == 0 ? 0.0
                                 : p.prefactor * std::exp(-factor * m2) /
                                       (M_PI * volume * m2 * moduli[0][x] * moduli[1][y] * moduli[2][z]);
        }
    energy_weight.assign(nzc, 2.0);
    energy_weight[0] = 1;
    if (n[2] % 2 == 0) energy_weight[nzc - 1] = 1;
  }
};

class EwaldMesh {
 public:
  virtual ~EwaldMesh() = default;
  // Adds −∇E to f; returns the mesh energy when asked (else 0).
  virtual double add_forces(const Coords& q, Coords& f, bool energy) = 0;
  virtual void add_hessian_vector(const Coords& q, const Coords& u, Coords& out) = 0;
};

namespace {

template <class Real>
MeshKernels<Real> kernels_of(int p);
template <>
MeshKernels<double> kernels_of<double>(int p) {
  return mesh_kernels(p);
}
template <>
MeshKernels<float> kernels_of<float>(int p) {
  return single_mesh_kernels(p);
}

// One precision's mesh: spline weights of the last positions, per-thread spreading grids, and two
// transform grids (the charges' and, for Hessian–vector products, their directional derivative's).
template <class Real>
class PrecisionMesh final : public EwaldMesh {
 public:
  explicit PrecisionMesh(std::shared_ptr<const EwaldMeshSetup> setup)
      : s_(std::move(setup)),
        n_atoms_(static_cast<int>(s_->charge.size())),
        kernels_(kernels_of<Real>(s_->order)),
        influence_(s_->influence.begin(), s_->influence.end()),
        weight_(s_->energy_weight.begin(), s_->energy_weight.end()),
        grid_{FftGrid<Real>(s_->n, s_->row), FftGrid<Real>(s_->n, s_->row)} {
    const int p = s_->order, stride = spline_stride(p);
    threaded_ = double(n_atoms_) * p * p * p + double(s_->n[0]) * s_->n[1] * s_->n[2] >= kParallelWork;
    for (int d = 0; d < 2; ++d)
      for (int i = 0; i < s_->n[d] + p; ++i) wrap_[d].push_back(i % s_->n[d]);
    atoms_.charge = s_->charge.data();
    atoms_.n = s_->n;
    atoms_.row = s_->row;
    for (int d = 0; d < 3; ++d) {
      atoms_.scale[d] = s_->scale[d];
      cell_[d].resize(n_atoms_);
      atoms_.cell[d] = cell_[d].data();
      for (auto* w : {&value_[d], &first_[d], &second_[d]}) w->resize(std::size_t(n_atoms_) * stride);
      atoms_.value[d] = value_[d].data();
      atoms_.first[d] = first_[d].data();
      atoms_.second[d] = second_[d].data();
    }
    atoms_.wrap_x = wrap_[0].data();
    atoms_.wrap_y = wrap_[1].data();
  }

  double add_forces(const Coords& q, Coords& f, bool energy) override {
    in_parallel([&](int t, int nt) {
      splines(q, false, t, nt);
      spread(grid_[0], nullptr, t, nt);
      partial_[t] = convolve(grid_[0], energy, t, nt);
#pragma omp barrier
      for (int k = 0; k < nt; ++k) {
        const auto& atoms = slab_atoms(k, t, nt);
        kernels_.gather_forces(atoms_, grid_[0].real(), atoms.data(), static_cast<int>(atoms.size()), f.data());
      }
    });
    phi_at_ = q;
    phi_ready_ = true;
    double sum = 0;
    for (double e : partial_) sum += e;  // in thread order: reproducible
    return 0.5 * sum;
  }

  void add_hessian_vector(const Coords& q, const Coords& u, Coords& out) override {
    // A Hessian–vector product at the positions of the last force pass (the integrators' usual
    // pattern) takes its potential grid: the same arithmetic, so the same result.
    const bool reuse = phi_ready_ && phi_at_.cols() == q.cols() && phi_at_ == q;
    in_parallel([&](int t, int nt) {
      splines(q, true, t, nt);
      if (!reuse) {
        spread(grid_[0], nullptr, t, nt);
        convolve(grid_[0], false, t, nt);
      }
      spread(grid_[1], &u, t, nt);
      convolve(grid_[1], false, t, nt);
#pragma omp barrier
      for (int k = 0; k < nt; ++k) {
        const auto& atoms = slab_atoms(k, t, nt);
        kernels_.gather_hessian(atoms_, grid_[0].real(), grid_[1].real(), u.data(), atoms.data(),
                                static_cast<int>(atoms.size()), out.data());
      }
    });
    phi_at_ = q;
    phi_ready_ = true;
  }

 private:
  // f(t, nt) on every thread of one parallel region (one thread below the work threshold); the
  // steps inside meet at barriers.
  template <class F>
  void in_parallel(F&& f) {
    const int threads = threaded_ ? omp_get_max_threads() : 1;
    if (slab_threads_ != threads) make_slabs(threads);
    partial_.assign(threads, 0.0);
    for (auto& grid : grid_) grid.prepare(threads);
#pragma omp parallel num_threads(threads)
    {
      const int nt = omp_get_num_threads();
      if (nt != threads) {  // fewer than asked for (a nested region): every thread of the team sees it
#pragma omp single
        make_slabs(nt);
      }
      f(omp_get_thread_num(), nt);
    }
  }

  // Thread t owns the x planes the transforms give it (FftGrid::planes) and spreads the atoms whose
  // first plane is one of them, as GROMACS's PME does: its grid is its planes and the p − 1 after,
  // so the sum of the grids reads only the neighbours' last planes, where atoms taken by number
  // would put charges all over every thread's grid.
  void make_slabs(int nt) {
    const int nx = s_->n[0], p = s_->order;
    const std::size_t plane = std::size_t(s_->n[1]) * s_->row;
    share_owners(nx, nt, owner_);  // FftGrid::planes' split
    local_x_.assign(nt, std::vector<int>(nx + p));
    first_plane_.resize(nt);
    spread_.resize(nt);
    for (int t = 0; t < nt; ++t) {
      const Share planes = share_of(nx, t, nt);
      for (int i = 0; i < nx + p; ++i) local_x_[t][i] = i - planes.begin;  // read for i ≥ planes.begin only
      first_plane_[t] = planes.begin;
      spread_[t].resize((planes.end - planes.begin + p - 1) * plane);
    }
    slab_atoms_.resize(std::size_t(nt) * nt);
    slab_threads_ = nt;
  }

  // The charged atoms of thread k's share whose first x plane is thread t's.
  std::vector<int>& slab_atoms(int k, int t, int nt) { return slab_atoms_[std::size_t(k) * nt + t]; }

  // Cells and weights of the thread's share of the atoms, which it then sorts by slab.
  void splines(const Coords& q, bool second, int t, int nt) {
    const Share atoms = share_of(n_atoms_, t, nt);
    kernels_.splines(atoms_, q.data(), second, atoms.begin, atoms.end);
    for (int k = 0; k < nt; ++k) slab_atoms(t, k, nt).clear();
    const int* cell_x = cell_[0].data();
    for (int i = atoms.begin; i < atoms.end; ++i)
      if (s_->charge[i] != 0) slab_atoms(t, owner_[cell_x[i]], nt).push_back(i);
#pragma omp barrier
  }

  // Thread t's atoms' charges (u null) or their directional derivative Σ_j q_j ∇θ_j · u_j spread on
  // its own grid; after a barrier, the threads' grids summed (in thread order) on its x planes,
  // each row's wrap-around folded back, and the planes transformed in y and z.
  void spread(FftGrid<Real>& grid, const Coords* u, int t, int nt) {
    const int nx = s_->n[0], p = s_->order, ny = s_->n[1], nz = s_->n[2], row = s_->row;
    const std::size_t plane = std::size_t(ny) * row;
    std::fill(spread_[t].begin(), spread_[t].end(), Real(0));
    MeshAtoms<Real> slab = atoms_;
    slab.wrap_x = local_x_[t].data();
    for (int k = 0; k < nt; ++k) {
      const auto& atoms = slab_atoms(k, t, nt);
      kernels_.spread(slab, u ? u->data() : nullptr, atoms.data(), static_cast<int>(atoms.size()), spread_[t].data());
    }
#pragma omp barrier
    const Share planes = grid.planes(t, nt);
    for (int x = planes.begin; x < planes.end; ++x) {
      Real* out = grid.real() + x * plane;
      for (int y = 0; y < ny; ++y) std::fill(out + y * row, out + y * row + nz, Real(0));
      for (int k = 0; k < nt; ++k) {
        const int extent = static_cast<int>(spread_[k].size() / plane);
        for (int local = (x - first_plane_[k] + nx) % nx; local < extent; local += nx) {
          const Real* in = spread_[k].data() + local * plane;
          for (int y = 0; y < ny; ++y) {
            Real* o = out + y * row;
            const Real* i = in + y * row;
            for (int z = 0; z < nz; ++z) o[z] += i[z];
            for (int z = 0; z < p - 1; ++z) o[z] += i[nz + z];
          }
        }
      }
    }
    grid.forward_planes(t, nt);
  }

  // After spread: the rest of the transform, the product with the influence function on the
  // thread's columns (with their part of the energy Σ_m G(m)|S(m)|² when asked, returned) and the
  // transform back. The grid then holds G ⊛ grid on the thread's planes, with each row's first
  // p − 1 points repeated after its end for the gathers.
  double convolve(FftGrid<Real>& grid, bool energy, int t, int nt) {
#pragma omp barrier
    grid.forward_columns(t, nt);
    const int nx = s_->n[0], ny = s_->n[1], nzc = grid.complex_row();
    const Share rows = grid.rows(t, nt);
    auto* c = grid.complex();
    double e = 0;
    for (int x = 0; x < nx; ++x)
      for (int y = rows.begin; y < rows.end; ++y) {
        const std::size_t at = (std::size_t(x) * ny + y) * nzc;
        for (int z = 0; z < nzc; ++z) {
          const Real g = influence_[at + z];
          if (energy) e += double(weight_[z] * g * std::norm(c[at + z]));
          c[at + z] *= g;
        }
      }
    grid.backward_columns(t, nt);
#pragma omp barrier
    grid.backward_planes(t, nt);
    Real* real = grid.real();
    const int nz = s_->n[2], row = s_->row, p = s_->order;
    const Share planes = grid.planes(t, nt);
    for (int r = planes.begin * ny; r < planes.end * ny; ++r)
      for (int z = 0; z < p - 1; ++z) real[std::size_t(r) * row + nz + z] = real[std::size_t(r) * row + z];
    return e;
  }

  // Threads only where there is work enough to pay for starting them.
  static constexpr double kParallelWork = 65536;

  std::shared_ptr<const EwaldMeshSetup> s_;
  int n_atoms_;
  MeshKernels<Real> kernels_;
  std::vector<Real> influence_, weight_;
  std::array<std::vector<int>, 3> cell_;
  std::array<std::vector<Real>, 3> value_, first_, second_;  // per dimension, spline_stride(p) per atom
  std::array<std::vector<int>, 2> wrap_;                     // i mod n for x and y, i < n + p
  MeshAtoms<Real> atoms_;                                    // the kernels' view of the above
  // Slabs for slab_threads_ threads (make_slabs): each x plane's thread, each thread's first plane,
  // its local plane of x point i and its spreading grid, and the atoms sorted by slab.
  int slab_threads_ = 0;
  std::vector<int> owner_, first_plane_;
  std::vector<std::vector<int>> local_x_;
  std::vector<std::vector<Real>> spread_;
  std::vector<std::vector<int>> slab_atoms_;
  std::vector<double> partial_;                              // per thread
  FftGrid<Real> grid_[2];
  bool threaded_;
  Coords phi_at_;
  bool phi_ready_ = false;
};

template <class Real>
std::unique_ptr<EwaldMesh> make_mesh(std::shared_ptr<const EwaldMeshSetup> setup) {
  return std::make_unique<PrecisionMesh<Real>>(std::move(setup));
}

EwaldMesh& made(std::unique_ptr<EwaldMesh>& mesh, bool single, const std::shared_ptr<const EwaldMeshSetup>& setup) {
  if (!mesh) mesh = single ? make_mesh<float>(setup) : make_mesh<double>(setup);
  return *mesh;
}

}  // namespace

EwaldMeshTerm::EwaldMeshTerm(const System& system, const EwaldMeshParameters& p, bool mixed_precision)
    : setup_(std::make_shared<EwaldMeshSetup>(system, p)), mixed_(mixed_precision) {}

EwaldMeshTerm::~EwaldMeshTerm() = default;

double EwaldMeshTerm::net_charge_energy() const { return setup_->net_charge_energy; }

void EwaldMeshTerm::add_forces(const Coords& q, Coords& f, std::span<double> energies, const TermEvaluation& how) {
  const double start = omp_get_wtime();
  const bool single = mixed_ || how.single_precision;
  const double e = made(single ? single_ : double_, single, setup_).add_forces(q, f, !energies.empty());
  if (!energies.empty()) energies[0] += e + setup_->net_charge_energy;
  seconds_ += omp_get_wtime() - start;
}

void EwaldMeshTerm::add_hessian_vector(const Coords& q, const Coords& u, Coords& out, const TermEvaluation& how) {
  const double start = omp_get_wtime();
  const bool single = mixed_ || how.single_precision;
  made(single ? single_ : double_, single, setup_).add_hessian_vector(q, u, out);
  seconds_ += omp_get_wtime() - start;
}

void EwaldMeshTerm::add_single_point(const Coords& q, Coords& f, std::span<double> energies) const {
  // A mesh of its own: the term's grids and cached potential stay as they were.
  const auto mesh = mixed_ ? make_mesh<float>(setup_) : make_mesh<double>(setup_);
  const double e = mesh->add_forces(q, f, !energies.empty());
  if (!energies.empty()) energies[0] += e + setup_->net_charge_energy;
}

}  // namespace vimd
