// ClusterFactors' dense and sparse clusters (engine/constraint_layout.hpp).
#include <Eigen/OrderingMethods>
#include <Eigen/SparseCholesky>
#include <Eigen/SparseLU>

#include "engine/constraint_layout.hpp"

namespace vimd::constraint_internals {

namespace {

// SimplicialLDLT on a pattern that the Layout has already ordered for low fill, refactorised
// through Eigen's factorize_preordered: the public factorize() copies the matrix (a heap
// allocation) on every call, which a step must not do.
class PreorderedLDLT
    : public Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>, Eigen::Upper, Eigen::NaturalOrdering<int>> {
 public:
  // `full` holds both triangles; only the upper one is read.
  void refactorize(const Eigen::SparseMatrix<double>& full) { factorize_preordered<true>(full); }
};

}  // namespace

struct ClusterFactors::Dynamic {
  Eigen::MatrixXd dense_matrix;
  Eigen::PartialPivLU<Eigen::MatrixXd> dense;
  Eigen::SparseMatrix<double> matrix;
  PreorderedLDLT ldlt;
  Eigen::SparseLU<Eigen::SparseMatrix<double>, Eigen::COLAMDOrdering<int>> lu;
  bool ldlt_analysed = false, lu_analysed = false;
  bool symmetric = true;  // which of ldlt / lu holds the current factorisation
  Eigen::VectorXd rhs, x;
};

void ClusterFactors::DeleteDynamic::operator()(Dynamic* d) const { delete[] d; }

void ClusterFactors::bind(const std::shared_ptr<const Layout>& l) {
  if (layout == l) return;
  layout = l;
  factorized = false;
  small_inverse.assign(l->n_small, Eigen::Matrix3d::Identity());
  dynamic.reset(new Dynamic[l->dynamic.size()]);
  for (const auto& cl : l->clusters) {
    if (cl.kind == Kind::Small) continue;
    Dynamic& d = dynamic[cl.slot];
    const int m = cl.size();
    if (cl.kind == Kind::Dense) {
      d.dense_matrix.resize(m, m);
      d.dense = Eigen::PartialPivLU<Eigen::MatrixXd>(m);
    } else {
      d.matrix = l->dynamic[cl.slot].pattern;
    }
    d.rhs.resize(m);
    d.x.resize(m);
  }
  r_left.resize(3, l->atom_i.size());
  r_right.resize(3, l->atom_i.size());
}

bool ClusterFactors::factor_dynamic(const Layout::Cluster& cl, const Coords& rl, const Coords& rr, const double* w,
                                    bool symmetric) {
  const Layout& L = *layout;
  const int b = cl.begin, m = cl.size();
  Dynamic& d = dynamic[cl.slot];
  const Layout::Dynamic& ld = L.dynamic[cl.slot];
  if (cl.kind == Kind::Dense) {
    d.dense_matrix.setZero();
    for (int a = 0; a < m; ++a)
      d.dense_matrix(a, a) = L.coefficient(b + a, b + a, w) * rl.col(b + a).dot(rr.col(b + a));
    for (const auto& e : ld.couplings)
      d.dense_matrix(e.a, e.b) = e.sign * w[e.atom] * rl.col(b + e.a).dot(rr.col(b + e.b));
    d.dense.compute(d.dense_matrix);
    d.symmetric = symmetric;
    return true;
  }
  double* values = d.matrix.valuePtr();
  for (int a = 0; a < m; ++a)
    values[ld.diagonal_position[a]] = L.coefficient(b + a, b + a, w) * rl.col(b + a).dot(rr.col(b + a));
  for (std::size_t k = 0; k < ld.couplings.size(); ++k) {
    const auto& e = ld.couplings[k];
    values[ld.coupling_position[k]] = e.sign * w[e.atom] * rl.col(b + e.a).dot(rr.col(b + e.b));
  }
  d.symmetric = symmetric;
  if (symmetric) {
    if (!d.ldlt_analysed) d.ldlt.analyzePattern(d.matrix), d.ldlt_analysed = true;
    d.ldlt.refactorize(d.matrix);
    return d.ldlt.info() == Eigen::Success;
  }
  if (!d.lu_analysed) d.lu.analyzePattern(d.matrix), d.lu_analysed = true;
  d.lu.factorize(d.matrix);
  return d.lu.info() == Eigen::Success;
}

void ClusterFactors::solve_dynamic(const Layout::Cluster& cl, double* x) {
  const int m = cl.size();
  Dynamic& d = dynamic[cl.slot];
  d.rhs = Eigen::Map<const Eigen::VectorXd>(x, m);
  if (cl.kind == Kind::Dense)
    d.x = d.dense.solve(d.rhs);
  else if (d.symmetric)
    d.x = d.ldlt.solve(d.rhs);
  else
    d.x = d.lu.solve(d.rhs);
  Eigen::Map<Eigen::VectorXd>(x, m) = d.x;
}

double* ClusterFactors::scratch(const Layout::Cluster& cl) { return dynamic[cl.slot].x.data(); }

}  // namespace vimd::constraint_internals
