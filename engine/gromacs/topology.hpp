#pragma once
// GROMACS .top reader with GROMACS's preprocessor (#include, #define, #undef, #ifdef, #ifndef,
// #else, #endif, ';' comments, '\' continuation). Produces the System of all molecules listed in
// [ molecules ]; the box stays zero (it comes from the structure file). Anything in a used molecule
// that vimd cannot compute (shells, CMAP, restraints, …) is an InputError at its file:line. Virtual
// sites ([ virtual_sites2 ], [ virtual_sites3 ]) become System::virtual_sites, checked as grompp does.
#include <filesystem>
#include <string>
#include <vector>

#include "engine/system.hpp"

namespace vimd {

// GROMACS's mdp option constraints: which bonds become rigid constraints at their length b0
// (h_bonds: those with a hydrogen, an atom whose name starts with H, grompp's rule).
enum class BondConstraints { none, h_bonds, all_bonds };

// grompp's rule for a hydrogen (topshake.cpp): the atom's name starts with H or h.
bool hydrogen_like(const std::string& atom_name);

// Runnable but suspicious input (as grompp's warnings, each naming its file:line) is appended to
// `warnings` when given.
System read_topology(const std::filesystem::path& top, BondConstraints bond_constraints = BondConstraints::none,
                     std::vector<std::string>* warnings = nullptr);

// Directories searched for an #include after the including file's own directory: the
// colon-separated $GMXLIB when set, else GROMACS's data directory /usr/share/gromacs/top.
std::vector<std::filesystem::path> gromacs_library_dirs();

}  // namespace vimd
