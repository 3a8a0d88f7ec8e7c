#pragma once
// Basic numeric types. GROMACS units throughout: nm, ps, amu, kJ/mol, e, K.
#include <omp.h>

#include <Eigen/Dense>
#include <algorithm>
#include <vector>

namespace vimd {

using Coords = Eigen::Matrix3Xd;  // one column per atom
using Vec3 = Eigen::Vector3d;

constexpr double kBoltzmann = 0.0083144626181532;  // kJ/mol/K
constexpr double kCoulomb = 138.935458;            // kJ/mol nm e^-2, GROMACS ONE_4PI_EPS0

// Per-atom loops (integrators, force zeroing, the run loop's checks, the neighbour list's
// displacement check) run on all threads from this many atoms, each with a static schedule, so a
// thread touches the same atoms in every one and their cache lines stay on its core. Below it,
// starting a team costs more than the work.
constexpr int kParallelMinAtoms = 256;

// Where thread t's contiguous share of n items begins when nt threads split them (t = nt: n).
inline int share_begin(int n, int t, int nt) { return static_cast<int>(static_cast<long>(n) * t / nt); }

// owner[i]: the thread whose share (share_begin) holds item i of n.
inline void share_owners(int n, int nt, std::vector<int>& owner) {
  owner.resize(n);
  for (int t = 0; t < nt; ++t)
    std::fill(owner.begin() + share_begin(n, t, nt), owner.begin() + share_begin(n, t + 1, nt), t);
}

// f(first, count) on each thread's contiguous share of n atoms; one share, on the calling
// thread, below kParallelMinAtoms.
template <class F>
void for_atom_shares(int n, F&& f) {
#pragma omp parallel if (n >= kParallelMinAtoms)
  {
    const int t = omp_get_thread_num(), nt = omp_get_num_threads();
    const int first = share_begin(n, t, nt);
    f(first, share_begin(n, t + 1, nt) - first);
  }
}

}  // namespace vimd
