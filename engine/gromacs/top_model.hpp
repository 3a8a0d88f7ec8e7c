#pragma once
// What the topology reader collects before it assembles the System: the force field's atom types
// and dihedral types, and the molecule types with the lines each entry came from (for errors).
#include <array>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "engine/gromacs/top_preprocessor.hpp"
#include "engine/system.hpp"

namespace vimd::top {

struct AtomType {
  std::string name, bonded_name;
  double mass, charge;
  char ptype;
  double v, w;  // c6, c12 (comb-rule 1) or sigma, epsilon (comb-rules 2, 3)
  Where where;
};

// A [ dihedraltypes ] line as grompp keeps it: bonded type names ("X": any), and the A-state
// parameters; `perturbed` when a B state differs (free-energy perturbation, refused where used).
struct DihedralType {
  std::array<std::string, 4> atoms;
  std::vector<double> params;
  bool perturbed = false;
  Where where;
};

struct MoleculeAtom {
  int type;  // index into the force field's atom types
  int residue_number;
  std::string residue_name, name;
  double charge, mass;
  char ptype;
  Where where;
};

// A [ virtual_sites2 ] or [ virtual_sites3 ] line.
struct SiteLine {
  VirtualSite site;
  Where where;
};

struct Unsupported {
  Where where;
  std::string what;
};

struct MoleculeType {
  std::string name;
  int nrexcl = 0;
  Where where;
  std::vector<MoleculeAtom> atoms;
  std::vector<Bond> bonds;
  std::vector<Angle> angles;
  std::vector<PeriodicDihedral> proper_dihedrals, periodic_impropers;
  std::vector<RyckaertBellemansDihedral> rb_dihedrals;
  std::vector<HarmonicImproper> harmonic_impropers;
  std::vector<Pair14> pairs14;
  std::vector<Constraint> constraints;
  int bonds_constrained = 0;  // of the constraints: bonds made rigid by the constraints option
  std::vector<Where> constraint_lines;  // per constraint: the [ constraints ] or [ settles ] line
  std::vector<std::pair<int, Where>> settles;  // each settle's oxygen and line
  std::vector<std::pair<int, int>> chemical_bonds;  // the graph nrexcl counts along
  std::vector<std::pair<int, int>> explicit_exclusions;
  std::vector<SiteLine> sites;  // in file order
  std::optional<Unsupported> unsupported;  // the first entry vimd cannot compute

  void mark_unsupported(const Where& where, const std::string& what) {
    if (!unsupported) unsupported = Unsupported{where, what};
  }
};

// An entry of [ molecules ].
struct MoleculeCount {
  int type;  // index into the molecule types
  int count;
};

}  // namespace vimd::top
