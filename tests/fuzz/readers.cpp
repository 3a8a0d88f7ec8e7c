#include "tests/fuzz/readers.hpp"

#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string_view>

#include "app/run_schema.hpp"
#include "engine/checkpoint.hpp"
#include "engine/config.hpp"
#include "engine/errors.hpp"
#include "engine/gromacs/gro.hpp"
#include "engine/gromacs/topology.hpp"

namespace vimd::fuzz {
namespace fs = std::filesystem;
namespace {

struct ScratchDir {
  fs::path path = fs::temp_directory_path() / ("vimd_fuzz_" + std::to_string(::getpid()));
  ScratchDir() {
    fs::create_directories(path);
    // Includes resolve against the scratch directory only, never the installed force fields.
    ::setenv("GMXLIB", path.c_str(), 1);
  }
  ~ScratchDir() {
    std::error_code ec;
    fs::remove_all(path, ec);
  }
};

const fs::path& scratch() {
  static const ScratchDir dir;
  return dir.path;
}

void write(const fs::path& file, std::string_view bytes) {
  std::ofstream out(file, std::ios::binary | std::ios::trunc);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  if (!out) throw std::runtime_error("fuzz: cannot write " + file.string());
}

}  // namespace

Reader reader_named(const std::string& name) {
  if (name == "gro") return Reader::Gro;
  if (name == "top") return Reader::Top;
  if (name == "toml") return Reader::Toml;
  if (name == "checkpoint") return Reader::Checkpoint;
  throw std::invalid_argument("unknown reader '" + name + "' (gro, top, toml, checkpoint)");
}

void read_bytes(Reader reader, const std::uint8_t* data, std::size_t size) {
  const std::string_view bytes(reinterpret_cast<const char*>(data), size);
  const fs::path& dir = scratch();
  std::vector<fs::path> files;
  switch (reader) {
    case Reader::Gro: files = {dir / "conf.gro"}; break;
    case Reader::Top: files = {dir / "topol.top", dir / "a.itp", dir / "b.itp"}; break;
    case Reader::Toml: files = {dir / "run.toml", dir / "conf.gro", dir / "topol.top"}; break;
    case Reader::Checkpoint: files = {dir / "state.cpt"}; break;
  }
  if (reader == Reader::Top) {
    std::string_view rest = bytes;
    for (const fs::path& file : files) {  // every part is rewritten, so no stale include survives
      const auto nul = std::min(rest.find('\0'), rest.size());
      write(file, rest.substr(0, nul));
      rest.remove_prefix(std::min(nul + 1, rest.size()));
    }
  } else if (reader == Reader::Checkpoint) {
    const std::uint64_t checksum = checkpoint_checksum(bytes.data(), bytes.size());
    write(files[0], std::string(bytes) + std::string(reinterpret_cast<const char*>(&checksum), sizeof checksum));
  } else {
    write(files[0], bytes);
    for (std::size_t k = 1; k < files.size(); ++k) write(files[k], "");
  }
  try {
    switch (reader) {
      case Reader::Gro: read_gro(files[0]); break;
      case Reader::Top: read_topology(files[0]); break;
      case Reader::Toml: read_config(files[0], run_schema()); break;
      case Reader::Checkpoint: read_checkpoint(files[0]); break;
    }
  } catch (const InputError& e) {
    for (const fs::path& file : files)
      if (fs::path(e.file()).lexically_normal() == file.lexically_normal()) return;
    throw std::logic_error(std::string("input error names no input file: ") + e.what());
  } catch (const std::exception& e) {
    throw std::logic_error(std::string("reader failed without an input error: ") + e.what());
  }
}

}  // namespace vimd::fuzz
