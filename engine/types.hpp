#pragma once
// Basic numeric types. GROMACS units throughout: nm, ps, amu, kJ/mol, e, K.
#include <Eigen/Dense>

namespace vimd {

using Coords = Eigen::Matrix3Xd;  // one column per atom
using Vec3 = Eigen::Vector3d;

constexpr double kBoltzmann = 0.0083144626181532;  // kJ/mol/K
constexpr double kCoulomb = 138.935458;            // kJ/mol nm e^-2, GROMACS ONE_4PI_EPS0

}  // namespace vimd
