// Replays fuzz inputs (seed corpus and the regressions found by fuzzing) through the readers:
//   fuzz_replay READER PATH...   (READER: gro, top, toml or checkpoint; PATH: files or directories)
// Exit 1 when any input makes a reader fail other than with an InputError naming its file.
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <vector>

#include "tests/fuzz/readers.hpp"

namespace fs = std::filesystem;

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: %s gro|top|toml|checkpoint PATH...\n", argv[0]);
    return 2;
  }
  const auto reader = vimd::fuzz::reader_named(argv[1]);
  std::vector<fs::path> inputs;
  for (int k = 2; k < argc; ++k) {
    if (fs::is_directory(argv[k])) {
      for (const auto& entry : fs::recursive_directory_iterator(argv[k]))
        if (entry.is_regular_file()) inputs.push_back(entry.path());
    } else {
      inputs.emplace_back(argv[k]);
    }
  }
  std::sort(inputs.begin(), inputs.end());
  int failures = 0;
  for (const fs::path& input : inputs) {
    std::ifstream in(input, std::ios::binary);
    if (!in) {
      std::fprintf(stderr, "FAIL %s: cannot read\n", input.c_str());
      ++failures;
      continue;
    }
    const std::vector<char> bytes{std::istreambuf_iterator<char>(in), {}};
    try {
      vimd::fuzz::read_bytes(reader, reinterpret_cast<const std::uint8_t*>(bytes.data()), bytes.size());
    } catch (const std::exception& e) {
      std::fprintf(stderr, "FAIL %s: %s\n", input.c_str(), e.what());
      ++failures;
    }
  }
  std::printf("%s reader: %zu inputs replayed, %d failed\n", argv[1], inputs.size(), failures);
  return failures == 0 && !inputs.empty() ? 0 : 1;
}
