#pragma once
// One entry point per input reader for the fuzz targets (clang + libFuzzer) and for the replay of
// their corpus in the test command (any compiler). The bytes become files in a scratch directory
// and go through the same reader a run uses. An InputError naming one of those files is the
// expected outcome of bad input; anything else (another exception, a crash, a sanitizer report,
// a hang) is a bug.
#include <cstddef>
#include <cstdint>
#include <string>

namespace vimd::fuzz {

enum class Reader { Gro, Top, Toml, Checkpoint };

// "gro", "top", "toml", "checkpoint"; throws std::invalid_argument for anything else.
Reader reader_named(const std::string& name);

// .gro: the bytes are conf.gro. .top: the bytes are split at NUL bytes into topol.top, a.itp and
// b.itp (so #include "a.itp" reaches fuzzed text; GMXLIB is the scratch directory). TOML: the
// bytes are run.toml next to empty conf.gro and topol.top. Checkpoint: the bytes followed by their
// checksum are state.cpt, so that fuzzing reaches the parser behind the checksum (a damaged file
// fails the checksum first; tests/test_checkpoint.cpp covers that). Throws std::logic_error when the reader
// fails in any way but an InputError naming one of the written files.
void read_bytes(Reader reader, const std::uint8_t* data, std::size_t size);

}  // namespace vimd::fuzz
