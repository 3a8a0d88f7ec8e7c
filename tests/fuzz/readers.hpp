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

enum class Reader { Gro, Top, Toml };

// "gro", "top", "toml"; throws std::invalid_argument for anything else.
Reader reader_named(const std::string& name);

// .gro: the bytes are conf.gro. .top: the bytes are split at NUL bytes into topol.top, a.itp and
// b.itp (so #include "a.itp" reaches fuzzed text; GMXLIB is the scratch directory). TOML: the
// bytes are run.toml next to empty conf.gro and topol.top. Throws std::logic_error when the reader
// fails in any way but an InputError naming one of the written files.
void read_bytes(Reader reader, const std::uint8_t* data, std::size_t size);

}  // namespace vimd::fuzz
