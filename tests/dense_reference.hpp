#pragma once
// Test-only dense reference for the variational integrator, for systems of a few atoms (see
// docs/variational-integrator.md, "What a correct implementation shows"):
// the maps ∂⁻, ∂⁺, L_h written out directly (explicit RK on (q, v, S) with the acceleration from the
// dense KKT system, projection by Newton on (x, θ)), their Jacobians by forward-mode automatic
// differentiation (dual numbers), the discrete momenta from their defining equation with Lagrange
// multipliers for T_w TQ, and a step by Gauss–Newton on the full discrete Euler–Lagrange equations
// with the Jacobian from nested dual numbers. Nothing here shares code with the fast solver except
// the tableau data. Also: LJ test systems, and a ForceTerm exposing them to the engine.
#include <Eigen/Dense>
#include <cmath>
#include <memory>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

#include "engine/constraints.hpp"
#include "engine/force_field.hpp"
#include "engine/integrator.hpp"
#include "engine/system.hpp"
#include "integrators/tableau.hpp"

namespace vimd::dense {

// ---------------------------------------------------------------- dual numbers (nestable)
template <class T>
struct Dual {
  T a{}, b{};  // value, derivative along the seeded direction
  Dual() = default;
  Dual(double x) : a(x), b(0.0) {}  // NOLINT: constants promote implicitly
  template <class U = T, std::enable_if_t<!std::is_same_v<U, double>, int> = 0>
  Dual(const T& x) : a(x), b(0.0) {}  // NOLINT
  Dual(const T& x, const T& dx) : a(x), b(dx) {}

  friend Dual operator+(const Dual& x, const Dual& y) { return {x.a + y.a, x.b + y.b}; }
  friend Dual operator-(const Dual& x, const Dual& y) { return {x.a - y.a, x.b - y.b}; }
  friend Dual operator*(const Dual& x, const Dual& y) { return {x.a * y.a, x.a * y.b + x.b * y.a}; }
  friend Dual operator/(const Dual& x, const Dual& y) {
    T q = x.a / y.a;
    return {q, (x.b - q * y.b) / y.a};
  }
  friend Dual operator-(const Dual& x) { return {-x.a, -x.b}; }
  Dual& operator+=(const Dual& y) { return *this = *this + y; }
  Dual& operator-=(const Dual& y) { return *this = *this - y; }
  Dual& operator*=(const Dual& y) { return *this = *this * y; }
};

inline double value(double x) { return x; }
template <class T>
double value(const Dual<T>& x) { return value(x.a); }

template <class T>
using Vec = std::vector<T>;

template <class T>
Vec<T> promote(const Vec<double>& x) {
  return Vec<T>(x.begin(), x.end());
}

// A x = rhs for dense row-major A (n×n), Gaussian elimination with partial pivoting on values.
template <class T>
Vec<T> solve_dense(Vec<T> A, Vec<T> rhs) {
  const int n = static_cast<int>(rhs.size());
  for (int k = 0; k < n; ++k) {
    int p = k;
    for (int i = k + 1; i < n; ++i)
      if (std::abs(value(A[i * n + k])) > std::abs(value(A[p * n + k]))) p = i;
    if (value(A[p * n + k]) == 0) throw std::runtime_error("dense reference: singular matrix");
    if (p != k) {
      for (int j = 0; j < n; ++j) std::swap(A[k * n + j], A[p * n + j]);
      std::swap(rhs[k], rhs[p]);
    }
    for (int i = k + 1; i < n; ++i) {
      T f = A[i * n + k] / A[k * n + k];
      for (int j = k; j < n; ++j) A[i * n + j] -= f * A[k * n + j];
      rhs[i] -= f * rhs[k];
    }
  }
  for (int i = n - 1; i >= 0; --i) {
    T s = rhs[i];
    for (int j = i + 1; j < n; ++j) s -= A[i * n + j] * rhs[j];
    rhs[i] = s / A[i * n + i];
  }
  return rhs;
}

// ---------------------------------------------------------------- small systems
struct DenseSystem {
  struct Bond {
    int i, j;
    double length;
  };
  struct Pair {
    int i, j;
    double epsilon, sigma;
  };
  std::vector<double> mass;
  std::vector<Bond> bonds;
  std::vector<Pair> pairs;

  int atoms() const { return static_cast<int>(mass.size()); }
  int dim() const { return 3 * atoms(); }
  int n_constraints() const { return static_cast<int>(bonds.size()); }

  // V = Σ 4ε(s¹² − s⁶) over the pairs, s = σ/r (written in r² so no square roots are needed).
  template <class T>
  T potential(const Vec<T>& q) const {
    T e = 0.0;
    for (const auto& p : pairs) {
      T r2 = 0.0;
      for (int k = 0; k < 3; ++k) {
        T d = q[3 * p.i + k] - q[3 * p.j + k];
        r2 += d * d;
      }
      T s2 = p.sigma * p.sigma / r2;
      T s6 = s2 * s2 * s2;
      e += 4 * p.epsilon * (s6 * s6 - s6);
    }
    return e;
  }
  template <class T>
  Vec<T> gradient(const Vec<T>& q) const {
    Vec<T> g(dim(), T(0.0));
    for (const auto& p : pairs) {
      T d[3], r2 = 0.0;
      for (int k = 0; k < 3; ++k) {
        d[k] = q[3 * p.i + k] - q[3 * p.j + k];
        r2 += d[k] * d[k];
      }
      T s2 = p.sigma * p.sigma / r2;
      T s6 = s2 * s2 * s2;
      T dv_dr2 = 4 * p.epsilon * (-6 * s6 * s6 + 3 * s6) / r2;
      for (int k = 0; k < 3; ++k) {
        g[3 * p.i + k] += 2 * dv_dr2 * d[k];
        g[3 * p.j + k] -= 2 * dv_dr2 * d[k];
      }
    }
    return g;
  }
  // g_a = ½(|q_i − q_j|² − d²)
  template <class T>
  Vec<T> g(const Vec<T>& q) const {
    Vec<T> out;
    for (const auto& b : bonds) {
      T r2 = 0.0;
      for (int k = 0; k < 3; ++k) {
        T d = q[3 * b.i + k] - q[3 * b.j + k];
        r2 += d * d;
      }
      out.push_back(0.5 * (r2 - b.length * b.length));
    }
    return out;
  }
  // Row a of G(x) applied to u: r_a·(u_i − u_j).
  template <class T, class U>
  auto G_apply(const Vec<T>& x, const Vec<U>& u) const {
    Vec<decltype(T() * U())> out;
    for (const auto& b : bonds) {
      decltype(T() * U()) s = 0.0;
      for (int k = 0; k < 3; ++k) s += (x[3 * b.i + k] - x[3 * b.j + k]) * (u[3 * b.i + k] - u[3 * b.j + k]);
      out.push_back(s);
    }
    return out;
  }
};

// Two rigid LJ dimers with the four inter-dimer pairs: systems.two_dimers() of the Python reference.
inline DenseSystem two_dimers(Vec<double>& q0, Vec<double>& v0) {
  DenseSystem s;
  s.mass = {1.0, 2.0, 1.5, 1.0};
  s.bonds = {{0, 1, 1.0}, {2, 3, 1.1}};
  s.pairs = {{0, 2, 1, 1}, {0, 3, 1, 1}, {1, 2, 1, 1}, {1, 3, 1, 1}};
  q0 = {0, 0, 0, 1.0, 0, 0, 0.3, 1.3, 0.2, 0.3 + 1.1 * std::cos(0.4), 1.3 + 1.1 * std::sin(0.4), 0.2};
  v0 = {0.1, 0.2, 0.0, -0.1, 0.3, 0.1, 0.0, -0.2, 0.1, 0.2, -0.1, -0.3};
  // Zero total momentum ("mom" in systems.py is Σ m v / Σ m, subtracted from every atom).
  double total = 0, mom[3] = {0, 0, 0};
  for (int i = 0; i < 4; ++i) {
    total += s.mass[i];
    for (int k = 0; k < 3; ++k) mom[k] += s.mass[i] * v0[3 * i + k];
  }
  for (int i = 0; i < 4; ++i)
    for (int k = 0; k < 3; ++k) v0[3 * i + k] -= mom[k] / total;
  // Mass-orthogonal projection onto G v = 0 (the two bonds do not share atoms).
  for (const auto& b : s.bonds) {
    double r[3], gv = 0, rr = 0;
    for (int k = 0; k < 3; ++k) {
      r[k] = q0[3 * b.i + k] - q0[3 * b.j + k];
      gv += r[k] * (v0[3 * b.i + k] - v0[3 * b.j + k]);
      rr += r[k] * r[k];
    }
    const double lam = gv / (rr * (1 / s.mass[b.i] + 1 / s.mass[b.j]));
    for (int k = 0; k < 3; ++k) {
      v0[3 * b.i + k] -= lam * r[k] / s.mass[b.i];
      v0[3 * b.j + k] += lam * r[k] / s.mass[b.j];
    }
  }
  return s;
}

// Unconstrained LJ trimer: systems.free_lj3().
inline DenseSystem free_trimer(Vec<double>& q0, Vec<double>& v0) {
  DenseSystem s;
  s.mass = {1.0, 1.3, 0.8};
  s.pairs = {{0, 1, 1, 1}, {0, 2, 1, 1}, {1, 2, 1, 1}};
  q0 = {0, 0, 0, 1.12, 0, 0, 0.5, 1.0, 0.1};
  v0 = {0.1, 0.0, 0.05, -0.1, 0.1, 0.0, 0.02, -0.1, -0.05};
  return s;
}

// A rigid triangle (three coupled constraints, like rigid water) and a free atom, LJ between the
// atom and the triangle. The start is exactly on the constraints; v0 is made tangent by the caller.
inline DenseSystem triangle_and_atom(Vec<double>& q0, Vec<double>& v0) {
  DenseSystem s;
  s.mass = {16.0, 1.0, 1.0, 12.0};
  const double a = 1.0, b = 1.0, c = 1.6;
  s.bonds = {{0, 1, a}, {0, 2, b}, {1, 2, c}};
  s.pairs = {{3, 0, 1.0, 1.0}, {3, 1, 0.3, 0.8}, {3, 2, 0.3, 0.8}};
  const double half = std::asin(0.5 * c / a);
  q0 = {0, 0, 0, a * std::cos(half), a * std::sin(half), 0, a * std::cos(half), -a * std::sin(half), 0,
        -0.4, 0.3, 1.15};
  v0 = {0.02, -0.03, 0.01, 0.2, 0.25, -0.1, -0.1, 0.15, 0.3, -0.05, 0.02, -0.04};
  return s;
}

// Two zig-zag chains of unit bonds, 6 and 18 atoms: the engine treats the first (5 constraints) as a
// dense cluster and the second (17) as a sparse one; LJ between the chains' ends. Velocities zero.
inline DenseSystem two_chains(Vec<double>& q0, Vec<double>& v0) {
  DenseSystem s;
  const int lengths[2] = {6, 18};
  const double half_angle = 0.95;  // half the bond angle (~109°)
  int first = 0;
  for (int chain = 0; chain < 2; ++chain) {
    for (int k = 0; k < lengths[chain]; ++k) {
      s.mass.push_back(1.0 + 0.25 * ((first + k) % 3));
      q0.insert(q0.end(), {k * std::sin(half_angle), (k % 2) * std::cos(half_angle), 2.5 * chain});
      if (k > 0) s.bonds.push_back({first + k - 1, first + k, 1.0});
    }
    first += lengths[chain];
  }
  s.pairs = {{0, 6, 1.0, 1.0}, {5, 11, 1.0, 1.0}};
  v0.assign(q0.size(), 0.0);
  return s;
}

// ---------------------------------------------------------------- the vector field and the maps
template <class T>
struct FlowResult {
  Vec<T> q, v;
  T action;
};

// A(q, v) from [[M, −Gᵀ], [−G, 0]] [a; λ] = [f; D²g(v,v)].
template <class T>
Vec<T> acceleration(const DenseSystem& s, const Vec<T>& q, const Vec<T>& v) {
  const int N = s.dim(), d = s.n_constraints(), n = N + d;
  Vec<T> f = s.gradient(q);
  for (auto& x : f) x = -x;
  Vec<T> K(n * n, T(0.0)), rhs(n, T(0.0));
  for (int i = 0; i < N; ++i) {
    K[i * n + i] = s.mass[i / 3];
    rhs[i] = f[i];
  }
  for (int a = 0; a < d; ++a) {
    const auto& b = s.bonds[a];
    T vv = 0.0;
    for (int k = 0; k < 3; ++k) {
      T r = q[3 * b.i + k] - q[3 * b.j + k];
      K[(3 * b.i + k) * n + N + a] = -r;
      K[(3 * b.j + k) * n + N + a] = r;
      K[(N + a) * n + 3 * b.i + k] = -r;
      K[(N + a) * n + 3 * b.j + k] = r;
      T dv = v[3 * b.i + k] - v[3 * b.j + k];
      vv += dv * dv;
    }
    rhs[N + a] = vv;
  }
  Vec<T> sol = solve_dense(std::move(K), std::move(rhs));
  sol.resize(N);
  return sol;
}

template <class T>
T lagrangian(const DenseSystem& s, const Vec<T>& q, const Vec<T>& v) {
  T kinetic = 0.0;
  for (int i = 0; i < s.dim(); ++i) kinetic += 0.5 * s.mass[i / 3] * v[i] * v[i];
  return kinetic - s.potential(q);
}

// Explicit RK on (q, v, S) over a signed time τ.
template <class T>
FlowResult<T> rk_flow(const DenseSystem& s, const ButcherTableau& tab, double tau, const Vec<T>& q,
                      const Vec<T>& v) {
  const int st = tab.stages(), N = s.dim();
  std::vector<Vec<T>> kq(st), kv(st);
  Vec<T> kl(st);
  for (int k = 0; k < st; ++k) {
    Vec<T> qk = q, vk = v;
    for (int j = 0; j < k; ++j) {
      if (tab.a(k, j) == 0) continue;
      for (int i = 0; i < N; ++i) {
        qk[i] += tau * tab.a(k, j) * kq[j][i];
        vk[i] += tau * tab.a(k, j) * kv[j][i];
      }
    }
    kv[k] = acceleration(s, qk, vk);
    kl[k] = lagrangian(s, qk, vk);
    kq[k] = vk;
  }
  FlowResult<T> out{q, v, T(0.0)};
  for (int k = 0; k < st; ++k) {
    for (int i = 0; i < N; ++i) {
      out.q[i] += tau * tab.b[k] * kq[k][i];
      out.v[i] += tau * tab.b[k] * kv[k][i];
    }
    out.action += tau * tab.b[k] * kl[k];
  }
  return out;
}

// P(y): x with y = x + W⁻¹G(x)ᵀθ, g(x) = 0, by Newton on (x, θ); iterated past convergence of
// the values so that (nested) derivative parts converge too.
template <class T>
Vec<T> project(const DenseSystem& s, const Vec<T>& y, const Vec<double>& inverse_weight) {
  const int N = s.dim(), d = s.n_constraints(), n = N + d;
  if (d == 0) return y;
  Vec<T> x = y, th(d, T(0.0));
  int extra = 0;
  for (int it = 0; it < 60 && extra < 4; ++it) {
    Vec<T> J(n * n, T(0.0)), rhs(n, T(0.0));
    for (int i = 0; i < N; ++i) {
      J[i * n + i] = 1.0;
      rhs[i] = y[i] - x[i];
    }
    Vec<T> gx = s.g(x);
    for (int a = 0; a < d; ++a) {
      const auto& b = s.bonds[a];
      const double wi = inverse_weight[b.i], wj = inverse_weight[b.j];
      for (int k = 0; k < 3; ++k) {
        const int I = 3 * b.i + k, Jx = 3 * b.j + k;
        T r = x[I] - x[Jx];
        rhs[I] -= wi * r * th[a];
        rhs[Jx] += wj * r * th[a];
        J[I * n + N + a] = wi * r;
        J[Jx * n + N + a] = -wj * r;
        J[(N + a) * n + I] = r;
        J[(N + a) * n + Jx] = -r;
        // W⁻¹ Σ θ_a H_a
        J[I * n + I] += wi * th[a];
        J[Jx * n + Jx] += wj * th[a];
        J[I * n + Jx] -= wi * th[a];
        J[Jx * n + I] -= wj * th[a];
      }
      rhs[N + a] = -gx[a];
    }
    Vec<T> dx = solve_dense(std::move(J), std::move(rhs));
    double change = 0;
    for (int i = 0; i < N; ++i) {
      x[i] += dx[i];
      change = std::max(change, std::abs(value(dx[i])));
    }
    for (int a = 0; a < d; ++a) th[a] += dx[N + a];
    if (change < 1e-15) ++extra;
  }
  if (extra == 0) throw std::runtime_error("dense reference: projection did not converge");
  return x;
}

// ---------------------------------------------------------------- the converted integrator
class DenseVariational {
 public:
  DenseVariational(DenseSystem system, ButcherTableau minus, ButcherTableau plus, double h, double alpha_minus,
                   double alpha_plus, bool mass_projection)
      : s_(std::move(system)), minus_(std::move(minus)), plus_(std::move(plus)), h_(h), am_(alpha_minus),
        ap_(alpha_plus) {
    for (int i = 0; i < s_.atoms(); ++i) weight_.push_back(mass_projection ? 1 / s_.mass[i] : 1.0);
  }
  const DenseSystem& system() const { return s_; }

  template <class T>
  struct Maps {
    Vec<T> xm, xp;
    T lh;
  };
  // ∂⁻(w), ∂⁺(w), L_h(w) with w = (q, v).
  template <class T>
  Maps<T> maps(const Vec<T>& q, const Vec<T>& v) const {
    Maps<T> m;
    FlowResult<T> p = rk_flow(s_, plus_, h_ * ap_, q, v);
    m.xp = project(s_, p.q, weight_);
    m.lh = p.action;
    if (am_ == 0) {
      m.xm = q;
    } else {
      FlowResult<T> mi = rk_flow(s_, minus_, h_ * am_, q, v);
      m.xm = project(s_, mi.q, weight_);
      m.lh -= mi.action;
    }
    return m;
  }

  // Values and Jacobians (forward mode, one direction per pass) of the maps at w.
  template <class T>
  struct Linearized {
    Maps<T> at;
    std::vector<Vec<T>> dxm, dxp;  // [direction][component], directions 0..2N−1 over (q, v)
    Vec<T> dlh;
  };
  template <class T>
  Linearized<T> linearize(const Vec<T>& q, const Vec<T>& v) const {
    const int N = s_.dim();
    Linearized<T> out;
    for (int j = 0; j < 2 * N; ++j) {
      Vec<Dual<T>> qd(q.begin(), q.end()), vd(v.begin(), v.end());
      (j < N ? qd[j] : vd[j - N]).b = 1.0;
      Maps<Dual<T>> m = maps(qd, vd);
      if (j == 0) {
        out.at.lh = m.lh.a;
        for (const auto& x : m.xm) out.at.xm.push_back(x.a);
        for (const auto& x : m.xp) out.at.xp.push_back(x.a);
      }
      Vec<T> a, b;
      for (const auto& x : m.xm) a.push_back(x.b);
      for (const auto& x : m.xp) b.push_back(x.b);
      out.dxm.push_back(a);
      out.dxp.push_back(b);
      out.dlh.push_back(m.lh.b);
    }
    return out;
  }

  // The covector DL_h + p⁻·D∂⁻ − p⁺·D∂⁺ − μ·C(w) over the 2N directions, C = [[G, 0], [Ġ, G]].
  template <class T>
  Vec<T> momentum_equation(const Linearized<T>& lin, const Vec<T>& q, const Vec<T>& v, const Vec<T>& pm,
                           const Vec<T>& pp, const Vec<T>& mu) const {
    const int N = s_.dim(), d = s_.n_constraints();
    Vec<T> r(2 * N);
    for (int j = 0; j < 2 * N; ++j) {
      T x = lin.dlh[j];
      for (int i = 0; i < N; ++i) x += pm[i] * lin.dxm[j][i] - pp[i] * lin.dxp[j][i];
      r[j] = x;
    }
    for (int a = 0; a < d; ++a) {
      const auto& b = s_.bonds[a];
      for (int k = 0; k < 3; ++k) {
        const int I = 3 * b.i + k, J = 3 * b.j + k;
        T rq = q[I] - q[J], rv = v[I] - v[J];
        r[I] -= mu[a] * rq + mu[d + a] * rv;
        r[J] += mu[a] * rq + mu[d + a] * rv;
        r[N + I] -= mu[d + a] * rq;
        r[N + J] += mu[d + a] * rq;
      }
    }
    return r;
  }

  // Discrete momenta p⁻(w), p⁺(w) (canonical: tangent at ∂⁻, ∂⁺) by one linear solve.
  void momenta(const Vec<double>& q, const Vec<double>& v, Vec<double>& xm, Vec<double>& xp, Vec<double>& pm,
               Vec<double>& pp) const {
    const int N = s_.dim(), d = s_.n_constraints(), n = 2 * N + 2 * d;
    Linearized<double> lin = linearize(q, v);
    xm = lin.at.xm;
    xp = lin.at.xp;
    // Unknowns (p⁻, p⁺, μ); equations: the momentum covector (2N), G(x⁻)p⁻ = 0, G(x⁺)p⁺ = 0.
    auto residual = [&](const Vec<double>& z) {
      Vec<double> a(z.begin(), z.begin() + N), b(z.begin() + N, z.begin() + 2 * N), mu(z.begin() + 2 * N, z.end());
      Vec<double> r = momentum_equation(lin, q, v, a, b, mu);
      for (double x : s_.G_apply(xm, a)) r.push_back(x);
      for (double x : s_.G_apply(xp, b)) r.push_back(x);
      return r;
    };
    Vec<double> zero(n, 0.0), r0 = residual(zero);
    Eigen::MatrixXd K(n, n);
    for (int c = 0; c < n; ++c) {
      Vec<double> e(n, 0.0);
      e[c] = 1;
      Vec<double> r = residual(e);
      for (int i = 0; i < n; ++i) K(i, c) = r[i] - r0[i];
    }
    Eigen::VectorXd z = K.fullPivLu().solve(-Eigen::Map<Eigen::VectorXd>(r0.data(), n));
    pm.assign(z.data(), z.data() + N);
    pp.assign(z.data() + N, z.data() + 2 * N);
  }

  // Residual of the step equations for z = (q, v, p⁺, μ) given (q̄, p̄):
  // g(q), G(q)v, ∂⁻(w) − q̄, the momentum covector with p⁻ = p̄, G(∂⁺(w)) p⁺.
  template <class T>
  Vec<T> step_residual(const Vec<T>& z, const Vec<double>& qbar, const Vec<double>& pbar) const {
    const int N = s_.dim();
    Vec<T> q(z.begin(), z.begin() + N), v(z.begin() + N, z.begin() + 2 * N), pp(z.begin() + 2 * N, z.begin() + 3 * N),
        mu(z.begin() + 3 * N, z.end());
    Linearized<T> lin = linearize(q, v);
    Vec<T> r = s_.g(q);
    for (const auto& x : s_.G_apply(q, v)) r.push_back(x);
    for (int i = 0; i < N; ++i) r.push_back(lin.at.xm[i] - qbar[i]);
    for (const auto& x : momentum_equation(lin, q, v, promote<T>(pbar), pp, mu)) r.push_back(x);
    for (const auto& x : s_.G_apply(lin.at.xp, pp)) r.push_back(x);
    return r;
  }

  // One step: Gauss–Newton from the guess (q, v, p⁺) with the exact Jacobian (nested duals).
  // Returns the iterations; (q, v) is the new point, (qbar, pbar) ← (∂⁺(w), p⁺(w)).
  int step(Vec<double>& q, Vec<double>& v, Vec<double>& qbar, Vec<double>& pbar, const Vec<double>& pplus_guess,
           double tolerance = 1e-14) const {
    const int N = s_.dim(), d = s_.n_constraints(), n = 3 * N + 2 * d;
    Vec<double> z;
    z.insert(z.end(), q.begin(), q.end());
    z.insert(z.end(), v.begin(), v.end());
    z.insert(z.end(), pplus_guess.begin(), pplus_guess.end());
    z.resize(n, 0.0);
    for (int it = 1; it <= 30; ++it) {
      Vec<double> r = step_residual(z, qbar, pbar);
      const int m = static_cast<int>(r.size());
      Eigen::MatrixXd J(m, n);
      for (int c = 0; c < n; ++c) {
        Vec<Dual<double>> zd(z.begin(), z.end());
        zd[c].b = 1.0;
        Vec<Dual<double>> rd = step_residual(zd, qbar, pbar);
        for (int i = 0; i < m; ++i) J(i, c) = rd[i].b;
      }
      Eigen::VectorXd dz = J.completeOrthogonalDecomposition().solve(-Eigen::Map<Eigen::VectorXd>(r.data(), m));
      for (int i = 0; i < n; ++i) z[i] += dz[i];
      if (dz.cwiseAbs().maxCoeff() < tolerance) {
        q.assign(z.begin(), z.begin() + N);
        v.assign(z.begin() + N, z.begin() + 2 * N);
        // (q̄, p̄) ← (∂⁺(w), p⁺) with p⁺ from the solve (already tangent at ∂⁺(w)).
        Linearized<double> lin = linearize(q, v);
        qbar = lin.at.xp;
        pbar.assign(z.begin() + 2 * N, z.begin() + 3 * N);
        return it;
      }
    }
    throw std::runtime_error("dense reference: Gauss-Newton did not converge");
  }

  // The standard layer's own step over h, as a predictor.
  void predict(const Vec<double>& q, const Vec<double>& v, Vec<double>& q1, Vec<double>& v1) const {
    FlowResult<double> f = rk_flow(s_, plus_, h_, q, v);
    q1 = f.q;
    v1 = f.v;
  }

 private:
  DenseSystem s_;
  ButcherTableau minus_, plus_;
  double h_, am_, ap_;
  Vec<double> weight_;  // W⁻¹ per atom
};

// ---------------------------------------------------------------- the same systems for the engine
// Lennard-Jones over an explicit pair list, no cut-off: V = 4ε(s¹² − s⁶) with s = σ/r.
class PairListLJ : public ForceTerm {
 public:
  explicit PairListLJ(std::vector<DenseSystem::Pair> pairs) : pairs_(std::move(pairs)) {}
  std::vector<std::string> energy_names() const override { return {"lj"}; }
  // Stateless: its forces are a single point's.
  void add_forces(const Coords& q, Coords& f, std::span<double> energies, const TermEvaluation& = {}) override {
    add_single_point(q, f, energies);
  }
  void add_single_point(const Coords& q, Coords& f, std::span<double> energies) const override {
    double unwanted[1] = {};  // forces only: the energies are computed and dropped
    if (energies.empty()) energies = unwanted;
    for (const auto& p : pairs_) {
      Vec3 r = q.col(p.i) - q.col(p.j);
      double s2 = p.sigma * p.sigma / r.squaredNorm(), s6 = s2 * s2 * s2;
      energies[0] += 4 * p.epsilon * (s6 * s6 - s6);
      Vec3 fi = -2 * derivative(p, r.squaredNorm()) * r;
      f.col(p.i) += fi;
      f.col(p.j) -= fi;
    }
  }
  // ∇²_r φ(|r|²) = 2φ′ I + 4φ″ r rᵀ, with φ′, φ″ derivatives in r².
  void add_hessian_vector(const Coords& q, const Coords& u, Coords& out, const TermEvaluation& = {}) override {
    for (const auto& p : pairs_) {
      Vec3 r = q.col(p.i) - q.col(p.j), du = u.col(p.i) - u.col(p.j);
      const double r2 = r.squaredNorm(), s2 = p.sigma * p.sigma / r2, s6 = s2 * s2 * s2;
      const double d2 = 4 * p.epsilon * (42 * s6 * s6 - 12 * s6) / (r2 * r2);
      Vec3 h = 2 * derivative(p, r2) * du + 4 * d2 * r * r.dot(du);
      out.col(p.i) += h;
      out.col(p.j) -= h;
    }
  }

 private:
  static double derivative(const DenseSystem::Pair& p, double r2) {
    double s2 = p.sigma * p.sigma / r2, s6 = s2 * s2 * s2;
    return 4 * p.epsilon * (-6 * s6 * s6 + 3 * s6) / r2;
  }
  std::vector<DenseSystem::Pair> pairs_;
};

// A dense system as an engine Problem. Not movable: Problem holds references to the members.
struct EngineProblem {
  System system;
  ForceField force_field;
  Constraints constraints;
  Problem problem;

  explicit EngineProblem(const DenseSystem& s)
      : system(make_system(s)),
        constraints(system.constraints, s.atoms(), Box{}),
        problem{system, force_field, constraints, system.mass.cwiseInverse()} {
    force_field.add(std::make_unique<PairListLJ>(s.pairs));
  }
  EngineProblem(const EngineProblem&) = delete;
  EngineProblem& operator=(const EngineProblem&) = delete;

  static System make_system(const DenseSystem& s) {
    System sys;
    sys.mass = Eigen::Map<const Eigen::VectorXd>(s.mass.data(), s.atoms());
    for (const auto& b : s.bonds) sys.constraints.push_back({b.i, b.j, b.length});
    sys.molecule.assign(s.atoms(), 0);
    return sys;
  }
};

inline Coords to_coords(const Vec<double>& x) { return Eigen::Map<const Coords>(x.data(), 3, x.size() / 3); }
inline Vec<double> to_vec(const Coords& x) { return Vec<double>(x.data(), x.data() + x.size()); }

}  // namespace vimd::dense
