#include <gtest/gtest.h>
#include <unistd.h>

#include <bit>
#include <cstdint>
#include <fstream>
#include <iterator>

#include "engine/gromacs/trr.hpp"

namespace fs = std::filesystem;
using namespace vimd;

namespace {

// An independent reader of the GROMACS double-precision .trr frame layout (XDR, big-endian).
class TrrReader {
 public:
  explicit TrrReader(const fs::path& file) {
    std::ifstream in(file, std::ios::binary);
    bytes_.assign(std::istreambuf_iterator<char>(in), {});
  }
  bool done() const { return pos_ == bytes_.size(); }
  std::int32_t integer() {
    std::uint32_t u = 0;
    for (int k = 0; k < 4; ++k) u = (u << 8) | byte();
    return static_cast<std::int32_t>(u);
  }
  double real() {
    std::uint64_t u = 0;
    for (int k = 0; k < 8; ++k) u = (u << 8) | byte();
    return std::bit_cast<double>(u);
  }
  std::string text(int n) {
    std::string s;
    for (int k = 0; k < n; ++k) s += static_cast<char>(byte());
    pos_ += (4 - n % 4) % 4;
    return s;
  }
  Coords coords(int natoms) {
    Coords c(3, natoms);
    for (int i = 0; i < natoms; ++i)
      for (int k = 0; k < 3; ++k) c(k, i) = real();
    return c;
  }

 private:
  unsigned byte() {
    if (pos_ >= bytes_.size()) throw std::runtime_error("read past end of file");
    return static_cast<unsigned char>(bytes_[pos_++]);
  }
  std::vector<char> bytes_;
  std::size_t pos_ = 0;
};

struct Frame {
  int x_size, v_size, f_size, natoms, step;
  double time, lambda;
  Eigen::Matrix3d box;
  Coords x, v, f;
};

Frame read_frame(TrrReader& r) {
  Frame fr;
  EXPECT_EQ(r.integer(), 1993);
  EXPECT_EQ(r.integer(), 13);  // strlen + 1
  EXPECT_EQ(r.integer(), 12);  // XDR string length
  EXPECT_EQ(r.text(12), "GMX_trn_file");
  EXPECT_EQ(r.integer(), 0);   // ir_size
  EXPECT_EQ(r.integer(), 0);   // e_size
  EXPECT_EQ(r.integer(), 72);  // box_size: 9 doubles
  for (int k = 0; k < 4; ++k) EXPECT_EQ(r.integer(), 0);  // vir, pres, top, sym
  fr.x_size = r.integer();
  fr.v_size = r.integer();
  fr.f_size = r.integer();
  fr.natoms = r.integer();
  fr.step = r.integer();
  EXPECT_EQ(r.integer(), 0);  // nre
  fr.time = r.real();
  fr.lambda = r.real();
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b) fr.box(a, b) = r.real();
  if (fr.x_size) fr.x = r.coords(fr.natoms);
  if (fr.v_size) fr.v = r.coords(fr.natoms);
  if (fr.f_size) fr.f = r.coords(fr.natoms);
  return fr;
}

}  // namespace

TEST(Trr, RoundTripsDoublePrecisionFrames) {
  const fs::path file = fs::temp_directory_path() / ("vimd_test_" + std::to_string(::getpid()) + ".trr");
  const int n = 5;
  const Coords x = Coords::Random(3, n), v = Coords::Random(3, n) * 3.0, f = Coords::Random(3, n) * 1e3;
  Box box;
  box.length = Vec3(1.5, 2.5, 3.5);
  {
    TrrWriter w(file, n);
    w.write(0, 0.0, box, &x, &v, &f);
    w.write(123456789, 246.913578, box, &x, nullptr, nullptr);
    EXPECT_THROW(w.write(1L << 33, 0.0, box, &x, nullptr, nullptr), std::out_of_range);
    const Coords wrong = Coords::Zero(3, n + 1);
    EXPECT_THROW(w.write(2, 0.0, box, &wrong, nullptr, nullptr), std::invalid_argument);
  }
  const std::size_t header = 4 + 4 + 4 + 12 + 13 * 4 + 2 * 8;
  const std::size_t block = n * 3 * 8;
  EXPECT_EQ(fs::file_size(file), (header + 72 + 3 * block) + (header + 72 + block));  // failed writes add nothing

  TrrReader r(file);
  const Frame a = read_frame(r);
  EXPECT_EQ(a.natoms, n);
  EXPECT_EQ(a.x_size, static_cast<int>(block));
  EXPECT_EQ(a.v_size, static_cast<int>(block));
  EXPECT_EQ(a.f_size, static_cast<int>(block));
  EXPECT_EQ(a.step, 0);
  EXPECT_EQ(a.time, 0.0);
  EXPECT_EQ(a.lambda, 0.0);
  EXPECT_EQ(a.box, Eigen::Matrix3d(box.length.asDiagonal()));
  EXPECT_EQ(a.x, x);  // bit-exact: double precision throughout
  EXPECT_EQ(a.v, v);
  EXPECT_EQ(a.f, f);

  const Frame b = read_frame(r);
  EXPECT_EQ(b.step, 123456789);
  EXPECT_EQ(b.time, 246.913578);
  EXPECT_EQ(b.v_size, 0);
  EXPECT_EQ(b.f_size, 0);
  EXPECT_EQ(b.x, x);
  EXPECT_TRUE(r.done());
  fs::remove(file);
}

TEST(Trr, RejectsUnwritablePathAndEmptySystems) {
  EXPECT_THROW(TrrWriter(fs::temp_directory_path() / "vimd_no_such_dir/x.trr", 3), std::runtime_error);
  EXPECT_THROW(TrrWriter(fs::temp_directory_path() / "vimd_empty.trr", 0), std::invalid_argument);
}
