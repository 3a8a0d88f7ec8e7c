#pragma once
// The System of a topology: the molecule types' atoms and interactions, copied as [ molecules ]
// lists them, with atom indices shifted per copy, exclusions from nrexcl and [ exclusions ], and
// the Lennard-Jones tables of the atom types used.
#include <string>
#include <vector>

#include "engine/gromacs/top_model.hpp"
#include "engine/gromacs/top_parameters.hpp"
#include "engine/system.hpp"

namespace vimd::top {

System assemble_system(const std::vector<MoleculeType>& molecules, const std::vector<MoleculeCount>& counts,
                       const ForceFieldParameters& parameters, const std::string& title);

}  // namespace vimd::top
