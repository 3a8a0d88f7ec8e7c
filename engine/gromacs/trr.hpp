#pragma once
// GROMACS .trr trajectory writer in double precision (XDR, big-endian): per frame step, time,
// box, and any of positions, velocities, forces. Readable by gmx check/trjconv and MDAnalysis.
#include <cstdio>
#include <filesystem>
#include <vector>

#include "engine/box.hpp"
#include "engine/types.hpp"

namespace vimd {

class TrrWriter {
 public:
  // Creates (truncates) the file, or appends to it (continuing a stopped run's trajectory).
  TrrWriter(const std::filesystem::path& file, int natoms, bool append = false);
  ~TrrWriter();
  TrrWriter(const TrrWriter&) = delete;
  TrrWriter& operator=(const TrrWriter&) = delete;

  // Appends one frame; null pointers leave that block out of the frame. Each frame is flushed,
  // so a crashed run keeps every frame written before it.
  void write(long step, double time, const Box& box, const Coords* x, const Coords* v, const Coords* f);

  const std::filesystem::path& path() const { return path_; }

 private:
  void put_int(int value);
  void put_double(double value);
  void put_coords(const Coords& c);

  std::filesystem::path path_;
  int natoms_;
  std::FILE* out_ = nullptr;
  std::vector<unsigned char> buffer_;
};

}  // namespace vimd
