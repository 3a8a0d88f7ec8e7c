#pragma once
// FNV-1a (64 bit) over bytes: a change of any one byte always changes the result (each step,
// xor with the byte then multiplication by an odd prime, is a bijection of the running value).
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <string>

namespace vimd {

class Fingerprint {
 public:
  void add_bytes(const void* data, std::size_t n) {
    const auto* p = static_cast<const unsigned char*>(data);
    for (std::size_t k = 0; k < n; ++k) hash_ = (hash_ ^ p[k]) * 1099511628211ull;
  }
  template <class T>
  void add(const T& x) {
    add_bytes(&x, sizeof x);
  }
  std::uint64_t value() const { return hash_; }
  std::string text() const {
    char buf[20];
    std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(hash_));
    return buf;
  }

 private:
  std::uint64_t hash_ = 14695981039346656037ull;
};

}  // namespace vimd
