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

  static void spread(const MeshAtoms<Real>& m, const double* u, int begin, int end, Real* grid) {
    const D d;
    const int ny = m.n[1], row = m.row;
    for (int i = begin; i < end; ++i) {
      const double q = m.charge[i];
      if (q == 0) continue;
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

  // F = −q s ∇(θ_x θ_y θ_z · φ), summed as Σ_a (θ'_x,a Σ_c θ_z,c S_ac, θ_x,a Σ_c θ_z,c D_ac, θ_x,a Σ_c θ'_z,c S_ac)
  // with S_a = Σ_b θ_y,b φ_ab and D_a = Σ_b θ'_y,b φ_ab vectors along z: a line of φ costs one load
  // and two FMAs, and the products of weights are taken per a, not per line.
  static void gather_forces(const MeshAtoms<Real>& m, const Real* phi, int begin, int end, double* f) {
    const D d;
    const int ny = m.n[1], row = m.row;
    for (int i = begin; i < end; ++i) {
      const double q = m.charge[i];
      if (q == 0) continue;
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
      auto fx = hn::Zero(d), fy = hn::Zero(d), fz = hn::Zero(d);
      for (int j = 0; j < V; ++j) {
        const auto weight_z = hn::LoadU(d, tz + j * L);
        fx = hn::MulAdd(along_x[j], weight_z, fx);
        fy = hn::MulAdd(along_y[j], weight_z, fy);
        fz = hn::MulAdd(along_z[j], hn::LoadU(d, dz + j * L), fz);
      }
      f[3 * i] -= q * m.scale[0] * sum(fx);
      f[3 * i + 1] -= q * m.scale[1] * sum(fy);
      f[3 * i + 2] -= q * m.scale[2] * sum(fz);
    }
  }

  static void gather_hessian(const MeshAtoms<Real>& m, const Real* phi, const Real* psi, const double* u, int begin,
                             int end, double* out) {
    const D d;
    const int ny = m.n[1], row = m.row;
    for (int i = begin; i < end; ++i) {
      const double q = m.charge[i];
      if (q == 0) continue;
      const std::size_t at = std::size_t(i) * S;
      const Real *tx = m.value[0] + at, *ty = m.value[1] + at, *tz = m.value[2] + at;
      const Real *dx = m.first[0] + at, *dy = m.first[1] + at, *dz = m.first[2] + at;
      const Real *ddx = m.second[0] + at, *ddy = m.second[1] + at, *ddz = m.second[2] + at;
      const int *wx = m.wrap_x + m.cell[0][i], *wy = m.wrap_y + m.cell[1][i];
      const std::size_t z0 = m.cell[2][i];
      auto hxx = hn::Zero(d), hyy = hn::Zero(d), hzz = hn::Zero(d), hxy = hn::Zero(d), hxz = hn::Zero(d),
           hyz = hn::Zero(d), gx = hn::Zero(d), gy = hn::Zero(d), gz = hn::Zero(d);
      for (int a = 0; a < P; ++a)
        for (int b = 0; b < P; ++b) {
          const std::size_t line = (std::size_t(wx[a]) * ny + wy[b]) * row + z0;
          const auto c_xx = hn::Set(d, ddx[a] * ty[b]), c_yy = hn::Set(d, tx[a] * ddy[b]),
                     c_00 = hn::Set(d, tx[a] * ty[b]), c_xy = hn::Set(d, dx[a] * dy[b]),
                     c_x0 = hn::Set(d, dx[a] * ty[b]), c_0y = hn::Set(d, tx[a] * dy[b]);
          for (int j = 0; j < V; ++j) {
            const auto t = hn::LoadU(d, tz + j * L), dt = hn::LoadU(d, dz + j * L);
            const auto lp = hn::LoadU(d, phi + line + j * L), ls = hn::LoadU(d, psi + line + j * L);
            const auto p0 = hn::Mul(lp, t), p1 = hn::Mul(lp, dt), s0 = hn::Mul(ls, t);
            hxx = hn::MulAdd(c_xx, p0, hxx);
            hyy = hn::MulAdd(c_yy, p0, hyy);
            hzz = hn::MulAdd(c_00, hn::Mul(lp, hn::LoadU(d, ddz + j * L)), hzz);
            hxy = hn::MulAdd(c_xy, p0, hxy);
            hxz = hn::MulAdd(c_x0, p1, hxz);
            hyz = hn::MulAdd(c_0y, p1, hyz);
            gx = hn::MulAdd(c_x0, s0, gx);
            gy = hn::MulAdd(c_0y, s0, gy);
            gz = hn::MulAdd(c_00, hn::Mul(ls, dt), gz);
          }
        }
      // Grid derivatives to Cartesian ones: each derivative in x_d brings a factor s_d = n_d/L_d.
      const double sx = m.scale[0], sy = m.scale[1], sz = m.scale[2];
      const double vx = sx * u[3 * i], vy = sy * u[3 * i + 1], vz = sz * u[3 * i + 2];
      const double Hxx = sum(hxx), Hyy = sum(hyy), Hzz = sum(hzz), Hxy = sum(hxy), Hxz = sum(hxz), Hyz = sum(hyz);
      out[3 * i] += q * sx * (Hxx * vx + Hxy * vy + Hxz * vz + sum(gx));
      out[3 * i + 1] += q * sy * (Hxy * vx + Hyy * vy + Hyz * vz + sum(gy));
      out[3 * i + 2] += q * sz * (Hxz * vx + Hyz * vy + Hzz * vz + sum(gz));
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
