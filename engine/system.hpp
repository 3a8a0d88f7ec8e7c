#pragma once
// The physical system as read from .gro + .top: per-atom data, interaction lists, box.
#include <array>
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

// Dihedral angle φ of i-j-k-l (IUPAC/GROMACS sign: the angle between the planes ijk and jkl, 180°
// trans), for the periodic, harmonic and Ryckaert–Bellemans forms.
struct PeriodicDihedral {  // V = k (1 + cos(n φ − phi_s)): GROMACS dihedral types 1, 9 (proper) and 4 (improper)
  int i, j, k, l;
  double phi_s;         // rad
  double force_constant;  // kJ/mol
  int multiplicity;
};

struct HarmonicImproper {  // V = ½ k (φ − xi0)², φ − xi0 taken in [−π, π): GROMACS dihedral type 2
  int i, j, k, l;
  double xi0;             // rad
  double force_constant;  // kJ/mol/rad²
};

struct RyckaertBellemansDihedral {  // V = Σ_n c_n cos^n(φ − 180°): GROMACS dihedral types 3 and 5 (converted)
  int i, j, k, l;
  std::array<double, 6> c;  // kJ/mol
};

struct Pair14 {  // 1–4 pair: V = c12/r¹² − c6/r⁶ + fudgeQQ f qi qj/(ε_r r), no cut-off
  int i, j;
  double c6, c12;  // kJ/mol nm⁶, kJ/mol nm¹² (fudgeLJ included where generated)
  double qq;       // fudgeQQ qi qj, e²
};

struct Constraint {  // |q_i − q_j| = length
  int i, j;
  double length;  // nm
};

// An atom whose position is a function of two or three others (GROMACS's [ virtual_sites2 ] and
// [ virtual_sites3 ]): massless, no degrees of freedom of its own; its forces act on the atoms it is
// built from. With r_ij = x_j − x_i, r_ik = x_k − x_i, r_jk = x_k − x_j (minimum images):
//   two:       x_i + a r_ij                      two_fd:    x_i + a r_ij/|r_ij|
//   three:     x_i + a r_ij + b r_ik             three_fd:  x_i + b t/|t|, t = r_ij + a r_jk
//   three_fad: x_i + a r_ij/|r_ij| + b p/|p|, p = r_jk − (r_ij·r_jk/|r_ij|²) r_ij
//   three_out: x_i + a r_ij + b r_ik + c r_ij × r_ik
struct VirtualSite {
  // In GROMACS's construction order: every [ virtual_sites2 ] kind before every [ virtual_sites3 ] kind.
  enum class Kind { two, two_fd, three, three_fd, three_fad, three_out };
  Kind kind;
  int site, i, j, k;  // k = -1 for the two-atom kinds
  double a, b, c;     // nm or dimensionless as the formula needs; three_fad: a = d cos θ, b = d sin θ (nm)
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
  std::vector<PeriodicDihedral> proper_dihedrals;  // energy "dihedrals"
  std::vector<RyckaertBellemansDihedral> rb_dihedrals;  // energy "dihedrals"
  std::vector<PeriodicDihedral> periodic_impropers;     // energy "impropers"
  std::vector<HarmonicImproper> harmonic_impropers;     // energy "impropers"
  std::vector<Pair14> pairs14;
  std::vector<Constraint> constraints;
  int bonds_constrained = 0;  // of the constraints: bonds made rigid by [system] constraints
  // In construction order: a site built from another site comes after it.
  std::vector<VirtualSite> virtual_sites;
  // Per atom: sorted indices of the atoms it has no nonbonded interaction with (both directions).
  std::vector<std::vector<int>> exclusions;

  Box box;

  int n_atoms() const { return static_cast<int>(mass.size()); }
  // "atom 5 (OW of SOL 2)": atom i, 1-based, with its names where the system has them.
  std::string atom_label(int i) const {
    std::string label = "atom " + std::to_string(i + 1);
    if (i < static_cast<int>(atom_names.size()) && i < static_cast<int>(residue_names.size()) &&
        i < static_cast<int>(residue_numbers.size()))
      label += " (" + atom_names[i] + " of " + residue_names[i] + " " + std::to_string(residue_numbers[i]) + ")";
    return label;
  }
  // 1/m per atom; 0 for a virtual site (no mass, no acceleration of its own).
  Eigen::VectorXd inverse_mass() const { return (mass.array() > 0).select(mass.cwiseInverse(), 0.0); }
  // Degrees of freedom for the temperature: 3N − constraints − 3 (removed centre-of-mass motion),
  // N counting the atoms that are not virtual sites.
  int degrees_of_freedom() const {
    return 3 * (n_atoms() - static_cast<int>(virtual_sites.size())) - static_cast<int>(constraints.size()) -
           (box.periodic() ? 3 : 0);
  }
};

}  // namespace vimd
