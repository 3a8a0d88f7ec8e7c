#pragma once
// GROMACS .top reader with GROMACS's preprocessor (#include, #define, #undef, #ifdef, #ifndef,
// #else, #endif, ';' comments, '\' continuation). Produces the System of all molecules listed in
// [ molecules ]; the box stays zero (it comes from the structure file). Anything in a used molecule
// that vimd cannot compute (pairs, dihedrals, virtual sites, …) is an InputError at its file:line.
#include <filesystem>
#include <vector>

#include "engine/system.hpp"

namespace vimd {

System read_topology(const std::filesystem::path& top);

// Directories searched for an #include after the including file's own directory: the
// colon-separated $GMXLIB when set, else GROMACS's data directory /usr/share/gromacs/top.
std::vector<std::filesystem::path> gromacs_library_dirs();

}  // namespace vimd
