// The Ewald mesh's per-atom loops, once per SIMD target (Highway's foreach_target re-includes this
// file for each) and per order P. An atom touches P × P rows of P contiguous z points: the z
// direction is vectorised (⌈P / lanes⌉ vectors, the weights zero beyond P), x and y are scalar.
#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "forcefields/ewald_mesh_kernels.cpp"
#include "hwy/foreach_target.h"  // IWYU pragma: keep

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <type_traits>
#include <utility>

#include "forcefields/bspline.hpp"
#include "forcefields/ewald_mesh_kernels.hpp"
#include "hwy/highway.h"

HWY_BEFORE_NAMESPACE();
namespace vimd {
namespace HWY_NAMESPACE {
namespace {

namespace hn = hwy::HWY_NAMESPACE;

template <class Real, int P>
struct OrderKernels {
  static constexpr int S = spline_stride(P);
  using D = hn::CappedTag<Real, S>;
  static constexpr int L = static_cast<int>(hn::MaxLanes(D()));
  static constexpr int V = (P + L - 1) / L;  // vectors per row of P points, V·L ≤ S

  // One atom's cell and weights in direction d, the reference for the vectors below.
  static void spline_of_atom(const MeshAtoms<Real>& m, const double* q, bool second, int i, int d) {
    const int n = m.n[d];
    double u = q[3 * i + d] * m.scale[d];  // grid coordinate
    u -= n * std::floor(u / n);
    int c = static_cast<int>(u);
    const Real t = static_cast<Real>(u - c);
    if (c >= n) c -= n;  // u rounded up to n
    m.cell[d][i] = c;
    SplineWeights<Real> w{};  // (second set only when asked: the compiler cannot tell)
    spline_weights(t, P, second, w);
    Real *value = m.value[d] + std::size_t(i) * S, *first = m.first[d] + std::size_t(i) * S;
    for (int k = 0; k < S; ++k) {
      value[k] = k < P ? w.value[k] : Real(0);
      first[k] = k < P ? w.first[k] : Real(0);
    }
    if (second) {
      Real* s = m.second[d] + std::size_t(i) * S;
      for (int k = 0; k < S; ++k) s[k] = k < P ? w.second[k] : Real(0);
    }
  }

  // Weights of as many atoms as a vector of doubles has lanes, for spline_weights to compute on
  // vectors with the same arithmetic as on numbers (friends defined in a class do not take the
  // target's pragma, hence HWY_ATTR).
  using DA = hn::ScalableTag<double>;
  using DW = hn::Rebind<Real, DA>;
  struct Lanes {
    hn::Vec<DW> v;
    Lanes() = default;
    HWY_ATTR Lanes(Real x) : v(hn::Set(DW(), x)) {}  // implicit, for the constants in spline_weights
    HWY_ATTR explicit Lanes(hn::Vec<DW> x) : v(x) {}
    friend HWY_ATTR Lanes operator+(Lanes a, Lanes b) { return Lanes(hn::Add(a.v, b.v)); }
    friend HWY_ATTR Lanes operator-(Lanes a, Lanes b) { return Lanes(hn::Sub(a.v, b.v)); }
    friend HWY_ATTR Lanes operator*(Lanes a, Lanes b) { return Lanes(hn::Mul(a.v, b.v)); }
    friend HWY_ATTR Lanes operator/(Lanes a, Lanes b) { return Lanes(hn::Div(a.v, b.v)); }
    friend HWY_ATTR Lanes operator-(Lanes a) { return Lanes(hn::Neg(a.v)); }
  };

  // Transposed stores (atom after atom, S weights each) exist for S = 4. Flattened, so that
  // spline_weights, compiled for no target, inlines here and its arithmetic on Lanes with it.
  [[gnu::flatten]] static void splines(const MeshAtoms<Real>& m, const double* q, bool second, int begin, int end) {
    int i = begin;
    if constexpr (S == 4) {
      const DA da;
      const DW dw;
      const hn::Rebind<int32_t, DA> di;
      constexpr int N = static_cast<int>(hn::MaxLanes(da));
      for (; i + N <= end; i += N) {
        hn::Vec<DA> x[3];
        hn::LoadInterleaved3(da, q + 3 * std::size_t(i), x[0], x[1], x[2]);
        for (int d = 0; d < 3; ++d) {
          const auto n = hn::Set(da, double(m.n[d]));
          auto u = hn::Mul(x[d], hn::Set(da, m.scale[d]));
          u = hn::Sub(u, hn::Mul(n, hn::Floor(hn::Div(u, n))));
          const auto c = hn::Trunc(u);
          const auto cell = hn::DemoteTo(di, c);
          hn::StoreU(hn::IfThenElseZero(hn::Lt(cell, hn::Set(di, m.n[d])), cell), di, m.cell[d] + i);
          SplineWeights<Lanes> w;
          spline_weights(Lanes(demoted(dw, hn::Sub(u, c))), P, second, w);
          const std::size_t at = std::size_t(i) * S;
          store_weights(w.value, m.value[d] + at);
          store_weights(w.first, m.first[d] + at);
          if (second) store_weights(w.second, m.second[d] + at);
        }
      }
    }
    for (; i < end; ++i)
      for (int d = 0; d < 3; ++d) spline_of_atom(m, q, second, i, d);
  }

  static hn::Vec<DW> demoted(DW dw, hn::Vec<DA> v) {
    if constexpr (std::is_same_v<Real, double>) return v;
    else return hn::DemoteTo(dw, v);
  }

  static void store_weights(const std::array<Lanes, kMaxSplineOrder>& w, Real* out) {
    const DW dw;
    const auto last = P > 3 ? w[3].v : hn::Zero(dw);
    hn::StoreInterleaved4(w[0].v, w[1].v, w[2].v, last, dw, out);
  }

  static void spread(const MeshAtoms<Real>& m, const double* u, const int* atoms, int count, Real* grid) {
    const D d;
    const int ny = m.n[1], row = m.row;
    for (int k = 0; k < count; ++k) {
      const int i = atoms[k];
      const double q = m.charge[i];
      const std::size_t at = std::size_t(i) * S;
      const Real *tx = m.value[0] + at, *ty = m.value[1] + at, *tz = m.value[2] + at;
      const Real *dx = m.first[0] + at, *dy = m.first[1] + at, *dz = m.first[2] + at;
      const int *wx = m.wrap_x + m.cell[0][i], *wy = m.wrap_y + m.cell[1][i];
      Real* base = grid + m.cell[2][i];
      if (!u) {
        // q θ_y,b θ_z once per atom; a line then costs one FMA with θ_x,a.
        hn::Vec<D> charge_yz[P][V];
        for (int b = 0; b < P; ++b)
          for (int j = 0; j < V; ++j)
            charge_yz[b][j] = hn::Mul(hn::Set(d, static_cast<Real>(q) * ty[b]), hn::LoadU(d, tz + j * L));
        for (int a = 0; a < P; ++a) {
          const auto weight_x = hn::Set(d, tx[a]);
          Real* plane = base + std::size_t(wx[a]) * ny * row;
          for (int b = 0; b < P; ++b) {
            Real* line = plane + std::size_t(wy[b]) * row;
            for (int j = 0; j < V; ++j)
              hn::StoreU(hn::MulAdd(weight_x, charge_yz[b][j], hn::LoadU(d, line + j * L)), d, line + j * L);
          }
        }
      } else {
        // q (u_x s_x θ'_x θ_y θ_z + u_y s_y θ_x θ'_y θ_z + u_z s_z θ_x θ_y θ'_z), s = n/L
        const Real ux = static_cast<Real>(q * u[3 * i] * m.scale[0]), uy = static_cast<Real>(q * u[3 * i + 1] * m.scale[1]),
                   uz = static_cast<Real>(q * u[3 * i + 2] * m.scale[2]);
        for (int a = 0; a < P; ++a) {
          const Real da = ux * dx[a], ya = uy * tx[a], za = uz * tx[a];
          for (int b = 0; b < P; ++b) {
            Real* line = base + (std::size_t(wx[a]) * ny + wy[b]) * row;
            const auto on_value = hn::Set(d, da * ty[b] + ya * dy[b]), on_first = hn::Set(d, za * ty[b]);
            for (int j = 0; j < V; ++j) {
              const auto sum = hn::MulAdd(on_first, hn::LoadU(d, dz + j * L), hn::LoadU(d, line + j * L));
              hn::StoreU(hn::MulAdd(on_value, hn::LoadU(d, tz + j * L), sum), d, line + j * L);
            }
          }
        }
      }
    }
  }

  static Real sum(hn::Vec<D> v) { return hn::GetLane(hn::SumOfLanes(D(), v)); }
  // Σ_c acc_c weight_c over the V vectors along z.
  static double z_sums(const hn::Vec<D>* acc, const Real* weight) {
    const D d;
    auto total = hn::Zero(d);
    for (int j = 0; j < V; ++j) total = hn::MulAdd(acc[j], hn::LoadU(d, weight + j * L), total);
    return static_cast<double>(sum(total));
  }

  // F = −q s ∇(θ_x θ_y θ_z · φ), summed as Σ_a (θ'_x,a Σ_c θ_z,c S_ac, θ_x,a Σ_c θ_z,c D_ac, θ_x,a Σ_c θ'_z,c S_ac)
  // with S_a = Σ_b θ_y,b φ_ab and D_a = Σ_b θ'_y,b φ_ab vectors along z: a line of φ costs one load
  // and two FMAs, and the products of weights are taken per a, not per line.
  static void gather_forces(const MeshAtoms<Real>& m, const Real* phi, const int* atoms, int count, double* f) {
    const D d;
    const int ny = m.n[1], row = m.row;
    for (int k = 0; k < count; ++k) {
      const int i = atoms[k];
      const double q = m.charge[i];
      const std::size_t at = std::size_t(i) * S;
      const Real *tx = m.value[0] + at, *ty = m.value[1] + at, *tz = m.value[2] + at;
      const Real *dx = m.first[0] + at, *dy = m.first[1] + at, *dz = m.first[2] + at;
      const int *wx = m.wrap_x + m.cell[0][i], *wy = m.wrap_y + m.cell[1][i];
      const Real* base = phi + m.cell[2][i];
      hn::Vec<D> along_x[V], along_y[V], along_z[V];
      for (int j = 0; j < V; ++j) along_x[j] = along_y[j] = along_z[j] = hn::Zero(d);
      for (int a = 0; a < P; ++a) {
        hn::Vec<D> value_y[V], first_y[V];
        for (int j = 0; j < V; ++j) value_y[j] = first_y[j] = hn::Zero(d);
        const Real* plane = base + std::size_t(wx[a]) * ny * row;
        for (int b = 0; b < P; ++b) {
          const Real* line = plane + std::size_t(wy[b]) * row;
          const auto weight = hn::Set(d, ty[b]), slope = hn::Set(d, dy[b]);
          for (int j = 0; j < V; ++j) {
            const auto l = hn::LoadU(d, line + j * L);
            value_y[j] = hn::MulAdd(weight, l, value_y[j]);
            first_y[j] = hn::MulAdd(slope, l, first_y[j]);
          }
        }
        const auto slope_x = hn::Set(d, dx[a]), weight_x = hn::Set(d, tx[a]);
        for (int j = 0; j < V; ++j) {
          along_x[j] = hn::MulAdd(slope_x, value_y[j], along_x[j]);
          along_y[j] = hn::MulAdd(weight_x, first_y[j], along_y[j]);
          along_z[j] = hn::MulAdd(weight_x, value_y[j], along_z[j]);
        }
      }
      f[3 * i] -= q * m.scale[0] * z_sums(along_x, tz);
      f[3 * i + 1] -= q * m.scale[1] * z_sums(along_y, tz);
      f[3 * i + 2] -= q * m.scale[2] * z_sums(along_z, dz);
    }
  }

  static void gather_hessian(const MeshAtoms<Real>& m, const Real* phi, const Real* psi, const double* u,
                             const int* atoms, int count, double* out) {
    const D d;
    const int ny = m.n[1], row = m.row;
    for (int k = 0; k < count; ++k) {
      const int i = atoms[k];
      const double q = m.charge[i];
      const std::size_t at = std::size_t(i) * S;
      const Real *tx = m.value[0] + at, *ty = m.value[1] + at, *tz = m.value[2] + at;
      const Real *dx = m.first[0] + at, *dy = m.first[1] + at, *dz = m.first[2] + at;
      const Real *ddx = m.second[0] + at, *ddy = m.second[1] + at, *ddz = m.second[2] + at;
      const int *wx = m.wrap_x + m.cell[0][i], *wy = m.wrap_y + m.cell[1][i];
      const Real* base_phi = phi + m.cell[2][i];
      const Real* base_psi = psi + m.cell[2][i];
      // As in gather_forces: the y weights along each line, the x weights per a, the z weights last.
      // Accumulators named by their (x, y) derivatives; their z weights are in the comments.
      hn::Vec<D> hxx[V], hyy[V], hzz[V], hxy[V], hxz[V], hyz[V], gx[V], gy[V], gz[V];
      for (int j = 0; j < V; ++j)
        hxx[j] = hyy[j] = hzz[j] = hxy[j] = hxz[j] = hyz[j] = gx[j] = gy[j] = gz[j] = hn::Zero(d);
      for (int a = 0; a < P; ++a) {
        hn::Vec<D> phi_y0[V], phi_y1[V], phi_y2[V], psi_y0[V], psi_y1[V];  // Σ_b θ_y^(k),b of φ, ψ
        for (int j = 0; j < V; ++j) phi_y0[j] = phi_y1[j] = phi_y2[j] = psi_y0[j] = psi_y1[j] = hn::Zero(d);
        const std::size_t plane = std::size_t(wx[a]) * ny * row;
        for (int b = 0; b < P; ++b) {
          const std::size_t line = plane + std::size_t(wy[b]) * row;
          const auto w0 = hn::Set(d, ty[b]), w1 = hn::Set(d, dy[b]), w2 = hn::Set(d, ddy[b]);
          for (int j = 0; j < V; ++j) {
            const auto lp = hn::LoadU(d, base_phi + line + j * L), ls = hn::LoadU(d, base_psi + line + j * L);
            phi_y0[j] = hn::MulAdd(w0, lp, phi_y0[j]);
            phi_y1[j] = hn::MulAdd(w1, lp, phi_y1[j]);
            phi_y2[j] = hn::MulAdd(w2, lp, phi_y2[j]);
            psi_y0[j] = hn::MulAdd(w0, ls, psi_y0[j]);
            psi_y1[j] = hn::MulAdd(w1, ls, psi_y1[j]);
          }
        }
        const auto x0 = hn::Set(d, tx[a]), x1 = hn::Set(d, dx[a]), x2 = hn::Set(d, ddx[a]);
        for (int j = 0; j < V; ++j) {
          hxx[j] = hn::MulAdd(x2, phi_y0[j], hxx[j]);  // θ_z
          hyy[j] = hn::MulAdd(x0, phi_y2[j], hyy[j]);  // θ_z
          hzz[j] = hn::MulAdd(x0, phi_y0[j], hzz[j]);  // θ''_z
          hxy[j] = hn::MulAdd(x1, phi_y1[j], hxy[j]);  // θ_z
          hxz[j] = hn::MulAdd(x1, phi_y0[j], hxz[j]);  // θ'_z
          hyz[j] = hn::MulAdd(x0, phi_y1[j], hyz[j]);  // θ'_z
          gx[j] = hn::MulAdd(x1, psi_y0[j], gx[j]);    // θ_z
          gy[j] = hn::MulAdd(x0, psi_y1[j], gy[j]);    // θ_z
          gz[j] = hn::MulAdd(x0, psi_y0[j], gz[j]);    // θ'_z
        }
      }
      // Grid derivatives to Cartesian ones: each derivative in x_d brings a factor s_d = n_d/L_d.
      const double sx = m.scale[0], sy = m.scale[1], sz = m.scale[2];
      const double vx = sx * u[3 * i], vy = sy * u[3 * i + 1], vz = sz * u[3 * i + 2];
      const double Hxx = z_sums(hxx, tz), Hyy = z_sums(hyy, tz), Hzz = z_sums(hzz, ddz), Hxy = z_sums(hxy, tz),
                   Hxz = z_sums(hxz, dz), Hyz = z_sums(hyz, dz);
      out[3 * i] += q * sx * (Hxx * vx + Hxy * vy + Hxz * vz + z_sums(gx, tz));
      out[3 * i + 1] += q * sy * (Hxy * vx + Hyy * vy + Hyz * vz + z_sums(gy, tz));
      out[3 * i + 2] += q * sz * (Hxz * vx + Hyz * vy + Hzz * vz + z_sums(gz, dz));
    }
  }

  static MeshKernels<Real> table() { return {splines, spread, gather_forces, gather_hessian}; }
};

template <class Real, int... P>
MeshKernels<Real> kernels_of_order(int p, std::integer_sequence<int, P...>) {
  MeshKernels<Real> k{};
  ((p == P + 3 ? (k = OrderKernels<Real, P + 3>::table(), 0) : 0), ...);
  return k;
}

}  // namespace

// Entry points of this target, for HWY_DYNAMIC_DISPATCH.
MeshKernels<double> MeshKernelsFor(int p) {
  return kernels_of_order<double>(p, std::make_integer_sequence<int, kMaxSplineOrder - 2>());
}
MeshKernels<float> SingleMeshKernelsFor(int p) {
  return kernels_of_order<float>(p, std::make_integer_sequence<int, kMaxSplineOrder - 2>());
}

}  // namespace HWY_NAMESPACE
}  // namespace vimd
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
#include <stdexcept>

namespace vimd {

HWY_EXPORT(MeshKernelsFor);
HWY_EXPORT(SingleMeshKernelsFor);

namespace {
template <class Kernels>
Kernels checked(Kernels k, int p) {
  if (!k.spread) throw std::invalid_argument("no Ewald mesh kernels for order " + std::to_string(p));
  return k;
}
}  // namespace

MeshKernels<double> mesh_kernels(int p) { return checked(HWY_DYNAMIC_DISPATCH(MeshKernelsFor)(p), p); }
MeshKernels<float> single_mesh_kernels(int p) { return checked(HWY_DYNAMIC_DISPATCH(SingleMeshKernelsFor)(p), p); }

}  // namespace vimd
#endif  // HWY_ONCE
