#pragma once
// The Ewald mesh's per-atom loops (forcefields/ewald_mesh.cpp): spline weights, spreading and
// gathering, compiled per SIMD target (Highway) and per B-spline order, chosen at run time. The
// vectors run along z, where an atom's p grid points are contiguous: its z weights are stored
// zero-padded to spline_stride(p) (a power of two, so whole vectors of any target's width up to
// it), and grid rows have room for that many points past the atom's first one.
#include <array>

namespace vimd {

// A power of two ≥ p: the storage of one atom's weights in one direction.
constexpr int spline_stride(int p) {
  int s = 1;
  while (s < p) s *= 2;
  return s;
}

// What the kernels read of the atoms and the grid. Positions, charges, u and forces are 3 × N
// column-major (Eigen's Coords) and double; weights and grids are Real.
template <class Real>
struct MeshAtoms {
  const double* charge;
  std::array<int, 3> n;    // grid points
  int row;                 // reals per grid row (x, y fixed), ≥ nz + spline_stride(p) − 1
  std::array<double, 3> scale;  // n/L
  std::array<int*, 3> cell;     // per atom
  // Per atom, spline_stride(p) each: θ, θ', θ'' in x, y, z (θ'' only for products).
  std::array<Real*, 3> value, first, second;
  const int* wrap_x;  // the grid plane of x point i < nx + p (i mod nx on the whole grid)
  const int* wrap_y;
};

template <class Real>
struct MeshKernels {
  // Cells and weights of atoms [begin, end) at positions q (wrapped into the box).
  void (*splines)(const MeshAtoms<Real>&, const double* q, bool second, int begin, int end);
  // The next three take the atoms listed, count of them, in any order.
  // Adds their charges to grid, or (u given) Σ q_j ∇θ_j · u_j; their x planes are wrap_x's.
  void (*spread)(const MeshAtoms<Real>&, const double* u, const int* atoms, int count, Real* grid);
  // f_i −= q_i Σ_g ∇θ_i φ(g).
  void (*gather_forces)(const MeshAtoms<Real>&, const Real* phi, const int* atoms, int count, double* f);
  // out_i += q_i Σ_g (∇∇θ_i u_i) φ(g) + q_i Σ_g ∇θ_i ψ(g).
  void (*gather_hessian)(const MeshAtoms<Real>&, const Real* phi, const Real* psi, const double* u, const int* atoms,
                         int count, double* out);
};

// The kernels of order p (3..12) for the best target of this CPU (or the one simd::use_target chose).
MeshKernels<double> mesh_kernels(int p);
MeshKernels<float> single_mesh_kernels(int p);

}  // namespace vimd
