#pragma once
// The physical system as read from .gro + .top: per-atom data, interaction lists, box.
#include <string>
#include <vector>

#include "engine/box.hpp"
#include "engine/types.hpp"

namespace vimd {

struct Bond {  // harmonic: V = ½ k (r − length)²
  int i, j;
  double length;  // nm
  double k;       // kJ/mol/nm²
};

struct Angle {  // harmonic in the angle: V = ½ k (θ − theta0)²
  int i, j, k;    // j is the vertex
  double theta0;  // rad
  double force_constant;  // kJ/mol/rad²
};

struct Constraint {  // |q_i − q_j| = length
  int i, j;
  double length;  // nm
};

struct System {
  std::string title;
  // Per atom, in .gro order.
  std::vector<std::string> atom_names, residue_names;
  std::vector<int> residue_numbers;
  std::vector<int> molecule;  // index of the molecule instance each atom belongs to
  Eigen::VectorXd mass;       // amu
  Eigen::VectorXd charge;     // e
  std::vector<int> type;      // index into type_names / c6 / c12

  // LJ parameters per type pair: V = c12/r¹² − c6/r⁶.
  std::vector<std::string> type_names;
  Eigen::MatrixXd c6, c12;  // kJ/mol nm⁶, kJ/mol nm¹²

  std::vector<Bond> bonds;
  std::vector<Angle> angles;
  std::vector<Constraint> constraints;
  // Per atom: sorted indices of the atoms it has no nonbonded interaction with (both directions).
  std::vector<std::vector<int>> exclusions;

  Box box;

  int n_atoms() const { return static_cast<int>(mass.size()); }
  // Degrees of freedom for the temperature: 3N − constraints − 3 (removed centre-of-mass motion).
  int degrees_of_freedom() const {
    return 3 * n_atoms() - static_cast<int>(constraints.size()) - (box.periodic() ? 3 : 0);
  }
};

}  // namespace vimd
