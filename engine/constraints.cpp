// Constraint geometry and the linear algebra with S = G W Gᵀ: the cluster layout built from the
// list, g and G, the factorisation per cluster and the solves that use it (the index-1
// acceleration, the projection onto ker G).
#include "engine/constraints.hpp"

#include <Eigen/OrderingMethods>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <utility>

#include "engine/constraint_layout.hpp"
#include "engine/errors.hpp"

namespace vimd {

using namespace constraint_internals;

namespace {

// max over k of f(k); NaN if any f(k) is NaN (so a blown-up state is never reported as fine).
template <class F>
double parallel_max(int n, F f) {
  double result = 0;
#pragma omp parallel if (n > kParallelMin)
  {
    double local = 0;
#pragma omp for schedule(static) nowait
    for (int k = 0; k < n; ++k) {
      const double x = f(k);
      if (x > local || std::isnan(x)) local = std::isnan(local) ? local : x;
    }
#pragma omp critical(vimd_constraints_max)
    if (local > result || std::isnan(local)) result = std::isnan(result) ? result : local;
  }
  return result;
}

// Every constraint joins two different atoms of the system at a positive length, and no pair twice
// (the constraint matrix would be singular).
void check_list(const std::vector<Constraint>& list, int n_atoms) {
  std::vector<std::pair<int, int>> pairs;
  pairs.reserve(list.size());
  for (std::size_t a = 0; a < list.size(); ++a) {
    const Constraint& c = list[a];
    const std::string name = "constraint " + std::to_string(a + 1) + " (atoms " + std::to_string(c.i + 1) + "-" +
                             std::to_string(c.j + 1) + ")";
    if (c.i < 0 || c.j < 0 || c.i >= n_atoms || c.j >= n_atoms)
      throw InputError("topology", 0, name + ": atom index outside 1.." + std::to_string(n_atoms));
    if (c.i == c.j) throw InputError("topology", 0, name + " joins an atom to itself");
    if (!(c.length > 0) || !std::isfinite(c.length))
      throw InputError("topology", 0, name + ": length must be positive, got " + format_number(c.length));
    pairs.emplace_back(std::min(c.i, c.j), std::max(c.i, c.j));
  }
  std::sort(pairs.begin(), pairs.end());
  if (auto dup = std::adjacent_find(pairs.begin(), pairs.end()); dup != pairs.end())
    throw InputError("topology", 0,
                     "atoms " + std::to_string(dup->first + 1) + " and " + std::to_string(dup->second + 1) +
                         " are constrained twice (the constraint matrix would be singular)");
}

// Connected components over shared atoms (union–find), as constraint indices, in order of their
// first constraint.
std::vector<std::vector<int>> coupled_clusters(const std::vector<Constraint>& list, int n_atoms) {
  std::vector<int> parent(n_atoms);
  for (int k = 0; k < n_atoms; ++k) parent[k] = k;
  auto root = [&](int k) {
    while (parent[k] != k) k = parent[k] = parent[parent[k]];
    return k;
  };
  for (const Constraint& c : list) parent[root(c.i)] = root(c.j);
  std::vector<std::vector<int>> clusters;
  std::vector<int> cluster_of_root(n_atoms, -1);
  for (int a = 0; a < static_cast<int>(list.size()); ++a) {
    int& id = cluster_of_root[root(list[a].i)];
    if (id < 0) id = static_cast<int>(clusters.size()), clusters.emplace_back();
    clusters[id].push_back(a);
  }
  return clusters;
}

// Builds the cluster-ordered Layout, cluster by cluster.
class LayoutBuilder {
 public:
  LayoutBuilder(Box box, int n_atoms) : layout_(std::make_shared<Layout>()), at_atom_(n_atoms) {
    Layout& L = *layout_;
    L.box = box;
    L.n_atoms = n_atoms;
    L.ones = Eigen::VectorXd::Ones(n_atoms);
  }

  void add_cluster(const std::vector<Constraint>& list, const std::vector<int>& members) {
    Layout& L = *layout_;
    Layout::Cluster cl;
    cl.begin = static_cast<int>(L.atom_i.size());
    cl.end = cl.begin + static_cast<int>(members.size());
    for (int a : members) {
      L.atom_i.push_back(list[a].i);
      L.atom_j.push_back(list[a].j);
      L.original.push_back(a);
      L.length.push_back(list[a].length);
    }
    const int m = cl.size();
    cl.kind = m <= kSmallMax ? Kind::Small : m <= kDenseMax ? Kind::Dense : Kind::Sparse;
    if (cl.kind == Kind::Small) {
      add_small(cl);
      return;
    }
    if (cl.kind == Kind::Sparse) order_for_little_fill(cl);
    add_dynamic(cl);
  }

  std::shared_ptr<const Layout> finish() {
    Layout& L = *layout_;
    L.consecutive_settle_batches = consecutive_settle_batches(L);
    L.atom_begin.push_back(0);
    for (const auto& cl : L.clusters) {
      for (int p = cl.begin; p < cl.end; ++p)
        for (int atom : {L.atom_i[p], L.atom_j[p]})
          if (std::find(L.atoms.begin() + L.atom_begin.back(), L.atoms.end(), atom) == L.atoms.end())
            L.atoms.push_back(atom);
      L.atom_begin.push_back(static_cast<int>(L.atoms.size()));
    }
    return std::move(layout_);
  }

 private:
  void add_small(Layout::Cluster cl) {
    Layout& L = *layout_;
    cl.slot = L.n_small++;
    L.triangles.push_back(rigid_triangle(L, cl));
    (L.triangles.back().valid ? L.triangle_clusters : L.other_clusters).push_back(static_cast<int>(L.clusters.size()));
    L.clusters.push_back(cl);
  }

  // Orders a sparse cluster's constraints once for little fill in LDLᵀ (a linear chain becomes
  // tridiagonal whatever order the topology lists it in); the factorisations then need no
  // permutation per call.
  void order_for_little_fill(const Layout::Cluster& cl) {
    Layout& L = *layout_;
    const int m = cl.size();
    Eigen::PermutationMatrix<Eigen::Dynamic, Eigen::Dynamic, int> perm;  // perm.indices()[new] = old
    Eigen::AMDOrdering<int>()(pattern_of(m, couplings(cl.begin, m)), perm);
    auto reorder = [&](auto& v) {
      const std::vector<typename std::decay_t<decltype(v)>::value_type> old(v.begin() + cl.begin, v.begin() + cl.end);
      for (int a = 0; a < m; ++a) v[cl.begin + a] = old[perm.indices()[a]];
    };
    reorder(L.atom_i);
    reorder(L.atom_j);
    reorder(L.original);
    reorder(L.length);
  }

  // A dense or sparse cluster: its couplings, and for a sparse one where S's entries sit.
  void add_dynamic(Layout::Cluster cl) {
    Layout& L = *layout_;
    const int m = cl.size();
    cl.slot = static_cast<int>(L.dynamic.size());
    Layout::Dynamic d;
    d.couplings = couplings(cl.begin, m);
    if (cl.kind == Kind::Sparse) {
      d.pattern = pattern_of(m, d.couplings);
      auto position = [&](int row, int col) {
        const int* inner = d.pattern.innerIndexPtr();
        const int* begin = inner + d.pattern.outerIndexPtr()[col];
        const int* end = inner + d.pattern.outerIndexPtr()[col + 1];
        return static_cast<int>(std::lower_bound(begin, end, row) - inner);
      };
      for (int a = 0; a < m; ++a) d.diagonal_position.push_back(position(a, a));
      for (const auto& e : d.couplings) d.coupling_position.push_back(position(e.a, e.b));
    }
    L.dynamic.push_back(std::move(d));
    L.other_clusters.push_back(static_cast<int>(L.clusters.size()));
    L.clusters.push_back(cl);
  }

  // The couplings of the constraints at positions [begin, begin + m), in their current order.
  std::vector<Layout::Coupling> couplings(int begin, int m) {
    const Layout& L = *layout_;
    std::vector<Layout::Coupling> found;
    for (int a = 0; a < m; ++a) {
      at_atom_[L.atom_i[begin + a]].push_back(a);
      at_atom_[L.atom_j[begin + a]].push_back(a);
    }
    for (int a = 0; a < m; ++a)
      for (int atom : {L.atom_i[begin + a], L.atom_j[begin + a]})
        for (int b : at_atom_[atom]) {
          if (b == a) continue;
          const double sa = L.atom_i[begin + a] == atom ? 1.0 : -1.0;
          const double sb = L.atom_i[begin + b] == atom ? 1.0 : -1.0;
          found.push_back({a, b, atom, sa * sb});
        }
    for (int a = 0; a < m; ++a) at_atom_[L.atom_i[begin + a]].clear(), at_atom_[L.atom_j[begin + a]].clear();
    return found;
  }

  // The structure of S for m constraints with these couplings (values unused).
  static Eigen::SparseMatrix<double> pattern_of(int m, const std::vector<Layout::Coupling>& couplings) {
    std::vector<Eigen::Triplet<double>> entries;
    for (int a = 0; a < m; ++a) entries.emplace_back(a, a, 1.0);
    for (const auto& e : couplings) entries.emplace_back(e.a, e.b, 1.0);
    Eigen::SparseMatrix<double> pattern(m, m);
    pattern.setFromTriplets(entries.begin(), entries.end());
    pattern.makeCompressed();
    return pattern;
  }

  std::shared_ptr<Layout> layout_;
  std::vector<std::vector<int>> at_atom_;  // scratch of couplings(): local constraint indices per atom
};

}  // namespace

Constraints::Constraints(std::vector<Constraint> list, int n_atoms, Box box)
    : list_(std::move(list)), box_(box) {
  check_list(list_, n_atoms);
  clusters_ = coupled_clusters(list_, n_atoms);
  LayoutBuilder builder(box_, n_atoms);
  for (const auto& members : clusters_) builder.add_cluster(list_, members);
  layout_ = builder.finish();

  const int n = size();
  work_ = std::make_unique<Workspace>();
  Workspace& ws = *work_;
  ws.factorization.factors().bind(layout_);
  ws.r_ref.resize(3, n);
  ws.r_cur.resize(3, n);
  ws.image.resize(3, n);
  ws.g.resize(n);
  ws.delta.resize(n);
  ws.lambda.resize(n);
  const std::size_t nc = clusters_.size();
  ws.iterations.assign(nc, 0);
  ws.worst.assign(nc, 0);
  ws.deviation.assign(nc, 0.0);
  ws.failed.assign(nc, 0);
  ws.singular.assign(nc, 0);
}

Constraints::Constraints() = default;
Constraints::~Constraints() = default;
Constraints::Constraints(Constraints&&) noexcept = default;
Constraints& Constraints::operator=(Constraints&&) noexcept = default;

Constraints::Factorization::Factorization() : impl_(std::make_unique<ClusterFactors>()) {}
Constraints::Factorization::~Factorization() = default;
Constraints::Factorization::Factorization(Factorization&&) noexcept = default;
Constraints::Factorization& Constraints::Factorization::operator=(Factorization&&) noexcept = default;

void Constraints::vectors(const Coords& q, Coords& r) const {
  r.resize(3, size());
  const int n = size();
#pragma omp parallel for schedule(static) if (n > kParallelMin)
  for (int a = 0; a < n; ++a) r.col(a) = box_.minimum_image(q.col(list_[a].i) - q.col(list_[a].j));
}

void Constraints::residuals(const Coords& q, Eigen::VectorXd& g) const {
  g.resize(size());
  const int n = size();
#pragma omp parallel for schedule(static) if (n > kParallelMin)
  for (int a = 0; a < n; ++a) {
    const Constraint& c = list_[a];
    g[a] = 0.5 * (box_.minimum_image(q.col(c.i) - q.col(c.j)).squaredNorm() - c.length * c.length);
  }
}

double Constraints::max_relative_deviation(const Coords& q) const {
  return parallel_max(size(), [&](int a) {
    const Constraint& c = list_[a];
    return relative_deviation(box_.minimum_image(q.col(c.i) - q.col(c.j)).squaredNorm(), c.length);
  });
}

double Constraints::max_velocity_residual(const Coords& q, const Coords& v) const {
  return parallel_max(size(), [&](int a) {
    const Constraint& c = list_[a];
    const Vec3 dv = v.col(c.i) - v.col(c.j);
    const double rate = box_.minimum_image(q.col(c.i) - q.col(c.j)).dot(dv);
    return std::abs(rate) / (c.length * std::max(1.0, dv.norm()));
  });
}

void Constraints::apply_G(const Coords& q, const Coords& u, Eigen::VectorXd& out) const {
  out.resize(size());
  const int n = size();
#pragma omp parallel for schedule(static) if (n > kParallelMin)
  for (int a = 0; a < n; ++a) {
    const Constraint& c = list_[a];
    out[a] = box_.minimum_image(q.col(c.i) - q.col(c.j)).dot(u.col(c.i) - u.col(c.j));
  }
}

// Atoms belong to one cluster only, so scattering per cluster is race-free.
void Constraints::add_GT(const Coords& q, const Eigen::VectorXd& lambda, Coords& out,
                         const Eigen::VectorXd& weights) const {
  if (empty()) return;
  const Layout& L = *layout_;
  const double* w = L.weights(weights);
  const int nc = static_cast<int>(L.clusters.size());
#pragma omp parallel for schedule(guided) if (size() > kParallelMin)
  for (int c = 0; c < nc; ++c)
    for (int p = L.clusters[c].begin; p < L.clusters[c].end; ++p) {
      const Vec3 r = L.bond(q, p) * lambda[L.original[p]];
      out.col(L.atom_i[p]) += w[L.atom_i[p]] * r;
      out.col(L.atom_j[p]) -= w[L.atom_j[p]] * r;
    }
}

void Constraints::add_H(const Eigen::VectorXd& c, const Coords& y, Coords& out, const Eigen::VectorXd& weights) const {
  if (empty()) return;
  const Layout& L = *layout_;
  const double* w = L.weights(weights);
  const int nc = static_cast<int>(L.clusters.size());
#pragma omp parallel for schedule(guided) if (size() > kParallelMin)
  for (int k = 0; k < nc; ++k)
    for (int p = L.clusters[k].begin; p < L.clusters[k].end; ++p) {
      const Vec3 dy = c[L.original[p]] * (y.col(L.atom_i[p]) - y.col(L.atom_j[p]));
      out.col(L.atom_i[p]) += w[L.atom_i[p]] * dy;
      out.col(L.atom_j[p]) -= w[L.atom_j[p]] * dy;
    }
}

void Constraints::factorize(const Coords& q_left, const Coords& q_right, const Eigen::VectorXd& weights,
                            Factorization& out) const {
  ClusterFactors& f = out.factors();
  f.factorized = false;
  if (empty()) return;
  const Layout& L = *layout_;
  L.check_coords(q_left, "q_left");
  L.check_coords(q_right, "q_right");
  const double* w = L.weights(weights);
  f.bind(layout_);
  const int n = size();
  const bool symmetric = &q_left == &q_right;
#pragma omp parallel for schedule(static) if (n > kParallelMin)
  for (int p = 0; p < n; ++p) {
    f.r_left.col(p) = L.bond(q_left, p);
    if (!symmetric) f.r_right.col(p) = L.bond(q_right, p);
  }
  const Coords& rr = symmetric ? f.r_left : f.r_right;
  const int nc = static_cast<int>(L.clusters.size());
  int singular = -1;
#pragma omp parallel for schedule(guided) if (n > kParallelMin)
  for (int c = 0; c < nc; ++c)
    if (!f.factor(L.clusters[c], f.r_left, rr, w, symmetric)) {
#pragma omp critical(vimd_constraints_singular)
      singular = std::max(singular, c);
    }
  if (singular >= 0)
    L.throw_singular(singular);
  f.symmetric = symmetric;
  f.factorized = true;
}

void Constraints::constrain_acceleration(const Coords& q, const Coords& v, const Eigen::VectorXd& weights, Coords& a,
                                         Eigen::VectorXd& lambda, Factorization& s) const {
  ClusterFactors& f = s.factors();
  f.factorized = false;
  lambda.resize(size());
  if (empty()) return;
  const Layout& L = *layout_;
  L.check_coords(q, "q");
  L.check_coords(v, "v");
  L.check_coords(a, "a");
  const double* w = L.weights(weights);
  f.bind(layout_);
  const int nc = static_cast<int>(L.clusters.size());
  int singular = -1;
#pragma omp parallel for schedule(guided) if (size() > kParallelMin)
  for (int c = 0; c < nc; ++c) {
    const auto& cl = L.clusters[c];
    for (int p = cl.begin; p < cl.end; ++p) f.r_left.col(p) = L.bond(q, p);
    if (!f.factor(cl, f.r_left, f.r_left, w, true)) {
#pragma omp critical(vimd_constraints_singular)
      singular = std::max(singular, c);
      continue;
    }
    double* x = work_->delta.data() + cl.begin;
    for (int k = 0; k < cl.size(); ++k) {
      const int p = cl.begin + k, i = L.atom_i[p], j = L.atom_j[p];
      x[k] = -f.r_left.col(p).dot(a.col(i) - a.col(j)) - (v.col(i) - v.col(j)).squaredNorm();
    }
    f.solve(cl, x);
    for (int k = 0; k < cl.size(); ++k) {
      const int p = cl.begin + k;
      lambda[L.original[p]] = x[k];
      L.move_along_bond(p, f.r_left.col(p), -x[k], w, a);
    }
  }
  if (singular >= 0)
    L.throw_singular(singular);
  f.symmetric = true;
  f.factorized = true;
}

void Constraints::project_onto_kernel(const Factorization& s, const Eigen::VectorXd& weights, Coords& u,
                                      Eigen::VectorXd& mu) const {
  mu.resize(size());
  if (empty()) return;
  ClusterFactors& f = s.factors();
  if (!f.factorized || !f.symmetric || f.layout != layout_)
    throw std::logic_error("Constraints::project_onto_kernel needs a symmetric factorisation of these constraints");
  const Layout& L = *layout_;
  L.check_coords(u, "u");
  const double* w = L.weights(weights);
  const int nc = static_cast<int>(L.clusters.size());
#pragma omp parallel for schedule(guided) if (size() > kParallelMin)
  for (int c = 0; c < nc; ++c) {
    const auto& cl = L.clusters[c];
    double* x = work_->delta.data() + cl.begin;
    for (int k = 0; k < cl.size(); ++k) {
      const int p = cl.begin + k;
      x[k] = f.r_left.col(p).dot(u.col(L.atom_i[p]) - u.col(L.atom_j[p]));
    }
    f.solve(cl, x);
    for (int k = 0; k < cl.size(); ++k) {
      const int p = cl.begin + k;
      mu[L.original[p]] = x[k];
      L.move_along_bond(p, f.r_left.col(p), x[k], w, u);
    }
  }
}

void Constraints::Factorization::solve(Eigen::VectorXd& rhs) const {
  if (!impl_->layout) {
    if (rhs.size() == 0) return;
    throw std::logic_error("Constraints::Factorization::solve called before factorize");
  }
  ClusterFactors& f = *impl_;
  const Layout& L = *f.layout;
  if (!f.factorized) throw std::logic_error("Constraints::Factorization::solve called before factorize");
  if (rhs.size() != static_cast<Eigen::Index>(L.original.size()))
    throw std::invalid_argument("Constraints::Factorization::solve: right-hand side has wrong size");
  const int nc = static_cast<int>(L.clusters.size());
#pragma omp parallel for schedule(guided) if (rhs.size() > kParallelMin)
  for (int c = 0; c < nc; ++c) {
    const auto& cl = L.clusters[c];
    double local[kSmallMax];
    double* x = cl.kind == Kind::Small ? local : f.scratch(cl);
    // Gather into cluster order; solve() copies dynamic clusters into their rhs buffer first,
    // so using x as the carrier does not alias.
    for (int a = 0; a < cl.size(); ++a) x[a] = rhs[L.original[cl.begin + a]];
    f.solve(cl, x);
    for (int a = 0; a < cl.size(); ++a) rhs[L.original[cl.begin + a]] = x[a];
  }
}

}  // namespace vimd
