#pragma once
// GROMACS .gro structures: reader for the fixed format and its variable-precision variant
// (gmx trjconv -ndec N), writer for the standard fixed format. Rectangular boxes only.
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "engine/box.hpp"
#include "engine/system.hpp"
#include "engine/types.hpp"

namespace vimd {

struct GroFrame {
  std::string title;
  std::vector<std::string> residue_names, atom_names;
  std::vector<int> residue_numbers;
  Coords x;                // nm
  std::optional<Coords> v; // nm/ps, when every atom line carries velocities
  Box box;
};

// Reads the first frame. Throws InputError (file, line, problem) on malformed input.
GroFrame read_gro(const std::filesystem::path& file);

// Writes positions at %8.3f and velocities (when v is given) at %8.4f, as GROMACS does; residue and
// atom numbers wrap modulo 100000. The file appears only when complete (written aside, then renamed).
void write_gro(const std::filesystem::path& file, const std::string& title, const System& system, const Coords& x,
               const Coords* v, const Box& box);

// Takes the box from the structure and checks it against the topology atom by atom, as grompp
// does: a different atom count is an InputError; different atom names return a warning (naming
// the structure's lines) and the topology's names stay.
std::vector<std::string> apply_structure(System& system, const GroFrame& frame, const std::filesystem::path& gro_file,
                                         const std::filesystem::path& top_file);

}  // namespace vimd
