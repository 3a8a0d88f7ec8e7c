#include "engine/gromacs/trr.hpp"

#include <bit>
#include <cerrno>
#include <climits>
#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <string>

namespace vimd {
namespace {

// Frame header as GROMACS's trrio writes it: magic, the version string in XDR string form
// (its length + 1 as an int, then the XDR string: length, bytes padded to 4), then 13 ints of
// block sizes, natoms, step, nre, and time and lambda as reals.
constexpr int kMagic = 1993;
constexpr char kVersion[] = "GMX_trn_file";
constexpr int kReal = sizeof(double);

}  // namespace

TrrWriter::TrrWriter(const std::filesystem::path& file, int natoms, bool append) : path_(file), natoms_(natoms) {
  if (natoms <= 0) throw std::invalid_argument("TrrWriter: number of atoms must be positive");
  out_ = std::fopen(file.c_str(), append ? "ab" : "wb");
  if (!out_) throw std::runtime_error("cannot write " + file.string() + ": " + std::strerror(errno));
}

TrrWriter::~TrrWriter() {
  if (out_) std::fclose(out_);
}

void TrrWriter::put_int(int value) {
  const auto u = static_cast<std::uint32_t>(value);
  for (int shift = 24; shift >= 0; shift -= 8) buffer_.push_back(static_cast<unsigned char>(u >> shift));
}

void TrrWriter::put_double(double value) {
  const auto u = std::bit_cast<std::uint64_t>(value);
  for (int shift = 56; shift >= 0; shift -= 8) buffer_.push_back(static_cast<unsigned char>(u >> shift));
}

void TrrWriter::put_coords(const Coords& c) {
  if (c.cols() != natoms_)
    throw std::invalid_argument("TrrWriter: frame has " + std::to_string(c.cols()) + " atoms, file has " +
                                std::to_string(natoms_));
  for (int i = 0; i < natoms_; ++i)
    for (int k = 0; k < 3; ++k) put_double(c(k, i));
}

void TrrWriter::write(long step, double time, const Box& box, const Coords* x, const Coords* v, const Coords* f) {
  // The format stores the step as a 32-bit int.
  if (step < INT_MIN || step > INT_MAX)
    throw std::out_of_range("TrrWriter: step " + std::to_string(step) + " does not fit the .trr step field");
  const int vector_bytes = natoms_ * 3 * kReal;
  buffer_.clear();
  put_int(kMagic);
  const int length = static_cast<int>(sizeof kVersion) - 1;
  put_int(length + 1);
  put_int(length);
  buffer_.insert(buffer_.end(), kVersion, kVersion + length);
  buffer_.resize(buffer_.size() + (4 - length % 4) % 4, 0);
  put_int(0);              // ir_size
  put_int(0);              // e_size
  put_int(9 * kReal);      // box_size
  put_int(0);              // vir_size
  put_int(0);              // pres_size
  put_int(0);              // top_size
  put_int(0);              // sym_size
  put_int(x ? vector_bytes : 0);
  put_int(v ? vector_bytes : 0);
  put_int(f ? vector_bytes : 0);
  put_int(natoms_);
  put_int(static_cast<int>(step));
  put_int(0);  // nre
  put_double(time);
  put_double(0.0);  // lambda
  for (int row = 0; row < 3; ++row)
    for (int col = 0; col < 3; ++col) put_double(row == col ? box.length[row] : 0.0);
  if (x) put_coords(*x);
  if (v) put_coords(*v);
  if (f) put_coords(*f);
  if (std::fwrite(buffer_.data(), 1, buffer_.size(), out_) != buffer_.size() || std::fflush(out_) != 0)
    throw std::runtime_error(path_.string() + ": cannot write (disk full?): " + std::strerror(errno));
}

}  // namespace vimd
