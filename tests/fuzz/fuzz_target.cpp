// libFuzzer entry for one reader, chosen at compile time (VIMD_FUZZ_READER = gro, top, toml or checkpoint).
#include "tests/fuzz/readers.hpp"

#define VIMD_STRINGIFY2(x) #x
#define VIMD_STRINGIFY(x) VIMD_STRINGIFY2(x)

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const vimd::fuzz::Reader reader = vimd::fuzz::reader_named(VIMD_STRINGIFY(VIMD_FUZZ_READER));
  vimd::fuzz::read_bytes(reader, data, size);  // a logic_error escapes: libFuzzer reports the input
  return 0;
}
