#pragma once
// The molecule-type sections of a topology: [ moleculetype ] and the sections inside one ([ atoms ],
// [ bonds ], [ angles ], [ dihedrals ], [ pairs ], [ constraints ], [ settles ], [ exclusions ],
// [ virtual_sites2 ], [ virtual_sites3 ]), read line by line into MoleculeTypes, with parameters
// from the force field's tables where a line has none of its own.
#include <cstddef>
#include <string>
#include <vector>

#include "engine/gromacs/top_fields.hpp"
#include "engine/gromacs/top_model.hpp"
#include "engine/gromacs/top_parameters.hpp"
#include "engine/gromacs/topology.hpp"

namespace vimd::top {

class MoleculeTypeReader {
 public:
  MoleculeTypeReader(const ForceFieldParameters& parameters, BondConstraints bond_constraints)
      : parameters_(parameters), bond_constraints_(bond_constraints) {}

  // The section readers, one data line each; all but moleculetype add to the last molecule type.
  void moleculetype(const Fields& f);
  void atom(const Fields& f);
  void bond(const Fields& f);
  void angle(const Fields& f);
  void dihedral(const Fields& f);
  void pair(const Fields& f);
  void constraint(const Fields& f);
  void settle(const Fields& f);
  void exclusion(const Fields& f);
  // A [ virtual_sites2 ] (from = 2) or [ virtual_sites3 ] (from = 3) line.
  void virtual_site(const Fields& f, int from);
  // A line of a section vimd cannot compute: refused if the molecule type is used.
  void unsupported(const Fields& f, const std::string& what) { molecules_.back().mark_unsupported(f.where(), what); }

  const std::vector<MoleculeType>& molecules() const { return molecules_; }

 private:
  const std::string& bonded_name(const MoleculeType& molecule, int atom) const {
    return parameters_.atomtypes()[molecule.atoms[atom].type].bonded_name;
  }

  const ForceFieldParameters& parameters_;
  BondConstraints bond_constraints_;
  std::vector<MoleculeType> molecules_;
};

}  // namespace vimd::top
