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

// Appends to `warnings` what is runnable but likely unintended: a settle whose pairs are not in
// [ exclusions ] (grompp, and so vimd, excludes them from nothing else).
System assemble_system(const std::vector<MoleculeType>& molecules, const std::vector<MoleculeCount>& counts,
                       const ForceFieldParameters& parameters, const std::string& title,
                       std::vector<std::string>& warnings);

}  // namespace vimd::top
