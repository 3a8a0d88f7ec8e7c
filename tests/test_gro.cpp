#include <gtest/gtest.h>

#include <unistd.h>

#include <fstream>

#include "engine/errors.hpp"
#include "engine/gromacs/gro.hpp"

namespace fs = std::filesystem;
using namespace vimd;

namespace {

const fs::path kData = fs::path(VIMD_SOURCE_DIR) / "tests/data/gro";

std::vector<std::string> read_lines(const fs::path& file) {
  std::ifstream in(file);
  std::vector<std::string> lines;
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

System named_system(int n) {
  System s;
  s.mass = Eigen::VectorXd::Ones(n);
  s.charge = Eigen::VectorXd::Zero(n);
  for (int i = 0; i < n; ++i) {
    s.atom_names.push_back(i % 3 == 0 ? "OW" : (i % 3 == 1 ? "HW1" : "HW2"));
    s.residue_names.push_back("SOL");
    s.residue_numbers.push_back(i / 3 + 1);
  }
  return s;
}

fs::path scratch_dir(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / ("vimd_test_gro_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

}  // namespace

TEST(Gro, ReadsFixedFormat) {
  const GroFrame f = read_gro(kData / "water2.gro");
  EXPECT_EQ(f.title, "Two SPC/E waters t=   0.00000 step= 0");
  ASSERT_EQ(f.x.cols(), 6);
  EXPECT_FALSE(f.v.has_value());
  EXPECT_EQ(f.atom_names, (std::vector<std::string>{"OW", "HW1", "HW2", "OW", "HW1", "HW2"}));
  EXPECT_EQ(f.residue_names[3], "SOL");
  EXPECT_EQ(f.residue_numbers, (std::vector<int>{1, 1, 1, 2, 2, 2}));
  EXPECT_DOUBLE_EQ(f.x(0, 0), 0.126);
  EXPECT_DOUBLE_EQ(f.x(1, 4), 0.233);
  EXPECT_DOUBLE_EQ(f.x(2, 5), 1.100);
  EXPECT_DOUBLE_EQ(f.box.length[0], 1.86206);
  EXPECT_DOUBLE_EQ(f.box.length[2], 1.86206);
}

TEST(Gro, ReadsVelocities) {
  const GroFrame f = read_gro(kData / "water2_vel.gro");
  ASSERT_TRUE(f.v.has_value());
  EXPECT_DOUBLE_EQ((*f.v)(0, 0), 0.1227);
  EXPECT_DOUBLE_EQ((*f.v)(1, 2), -2.6469);
  EXPECT_DOUBLE_EQ((*f.v)(2, 5), 0.9999);
  EXPECT_DOUBLE_EQ(f.x(0, 5), 1.195);
}

// The layout `gmx trjconv -ndec 8` wrote before GROMACS 2020 (x %13.8f, v %13.9f); GROMACS 2022
// reads this file (`gmx check -c`) but no longer writes .gro at other than 3 decimals.
TEST(Gro, ReadsVariablePrecision) {
  const GroFrame f = read_gro(kData / "water2_ndec8.gro");
  ASSERT_EQ(f.x.cols(), 6);
  ASSERT_TRUE(f.v.has_value());
  EXPECT_EQ(f.atom_names[4], "HW1");
  EXPECT_NEAR(f.x(0, 0), 0.12345678, 1e-12);
  EXPECT_NEAR(f.x(2, 5), 1.10000001, 1e-12);
  EXPECT_NEAR((*f.v)(1, 2), -2.646912345, 1e-12);
  EXPECT_NEAR(f.box.length[1], 1.86206, 1e-12);
}

TEST(Gro, MalformedFilesNameFileAndLine) {
  struct Case {
    const char* file;
    int line;
    const char* problem;
  };
  const Case cases[] = {
      {"bad_count.gro", 2, "number of atoms"},
      {"truncated.gro", 7, "file ends after 4 of 6 atoms"},
      {"bad_number.gro", 4, "cannot read coordinate y"},
      {"missing_box.gro", 6, "missing box line"},
      {"triclinic.gro", 6, "triclinic"},
      {"missing_velocity.gro", 4, "no velocities on this atom line"},
      {"late_velocity.gro", 4, "the first atom line (line 3) has none"},
      // The first atom line itself: its own problem, not a comparison with itself.
      {"short_velocity.gro", 3, "the text after z, '0.1227', is not three velocities of 8 columns each"},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.file);
    try {
      read_gro(kData / c.file);
      ADD_FAILURE() << "no error";
    } catch (const InputError& e) {
      EXPECT_EQ(e.line(), c.line);
      EXPECT_NE(std::string(e.what()).find(std::string(c.file) + ":" + std::to_string(c.line) + ": "),
                std::string::npos)
          << e.what();
      EXPECT_NE(std::string(e.what()).find(c.problem), std::string::npos) << e.what();
    }
  }
  EXPECT_THROW(read_gro(kData / "no_such_file.gro"), InputError);
}

TEST(Gro, WritesGromacsFixedFormatAndReadsItBack) {
  const fs::path dir = scratch_dir("write");
  System s = named_system(3);
  s.residue_numbers = {123456, 123456, 123456};  // wraps to 23456 as in GROMACS
  s.atom_names[1] = "HW1LONGNAME";               // GROMACS keeps 5 characters
  Coords x(3, 3), v(3, 3);
  x << 0.1234, -1.5, 10.0, 2.0, 0.0004, -0.0006, 3.14159, 2.71828, 1.0;
  v << 0.12341, -1.0, 0.0, 0.5, 0.25, -0.125, 1e-5, 3.0, -2.5;
  Box box;
  box.length = Vec3(1.5, 2.25, 3.125);
  const fs::path file = dir / "out.gro";
  write_gro(file, "a title", s, x, &v, box);

  const auto lines = read_lines(file);
  ASSERT_EQ(lines.size(), 6u);
  EXPECT_EQ(lines[0], "a title");
  EXPECT_EQ(lines[1], "    3");
  EXPECT_EQ(lines[2], "23456SOL     OW    1   0.123   2.000   3.142  0.1234  0.5000  0.0000");
  EXPECT_EQ(lines[3], "23456SOL  HW1LO    2  -1.500   0.000   2.718 -1.0000  0.2500  3.0000");
  EXPECT_EQ(lines[5], "   1.50000   2.25000   3.12500");
  EXPECT_FALSE(fs::exists(file.string() + ".partial"));

  const GroFrame back = read_gro(file);
  EXPECT_LE((back.x - x).cwiseAbs().maxCoeff(), 5e-4 + 1e-12);
  ASSERT_TRUE(back.v.has_value());
  EXPECT_LE((*back.v - v).cwiseAbs().maxCoeff(), 5e-5 + 1e-12);
  EXPECT_EQ(back.box.length, box.length);

  write_gro(file, "no velocities", s, x, nullptr, box);
  EXPECT_FALSE(read_gro(file).v.has_value());
  fs::remove_all(dir);
}

TEST(Gro, AtomNumbersWrapModulo100000) {
  const fs::path dir = scratch_dir("wrap");
  const int n = 100002;
  const System s = named_system(n);
  const Coords x = Coords::Zero(3, n);
  const fs::path file = dir / "big.gro";
  write_gro(file, "big", s, x, nullptr, Box{});
  const auto lines = read_lines(file);
  EXPECT_EQ(lines[2 + 99998].substr(15, 5), "99999");
  EXPECT_EQ(lines[2 + 99999].substr(15, 5), "    0");
  EXPECT_EQ(lines[2 + 100000].substr(15, 5), "    1");
  EXPECT_EQ(read_gro(file).x.cols(), n);
  fs::remove_all(dir);
}

TEST(Gro, FailedWriteLeavesNoFile) {
  const System s = named_system(3);
  const fs::path file = fs::temp_directory_path() / "vimd_no_such_dir" / "out.gro";
  EXPECT_THROW(write_gro(file, "t", s, Coords::Zero(3, 3), nullptr, Box{}), std::runtime_error);
  EXPECT_FALSE(fs::exists(file));
  EXPECT_THROW(write_gro(fs::temp_directory_path() / "x.gro", "t", s, Coords::Zero(3, 2), nullptr, Box{}),
               std::invalid_argument);
}

TEST(Gro, ApplyStructureChecksAtomsAgainstTopology) {
  const GroFrame frame = read_gro(kData / "water2.gro");
  System s = named_system(6);
  EXPECT_TRUE(apply_structure(s, frame, kData / "water2.gro", "topol.top").empty());
  EXPECT_EQ(s.box.length, frame.box.length);

  // As grompp: different names are a warning naming the first line, and the topology's names stay.
  System wrong_name = named_system(6);
  wrong_name.atom_names[4] = "HX";
  const auto warnings = apply_structure(wrong_name, frame, kData / "water2.gro", "topol.top");
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_NE(warnings[0].find("water2.gro:7: 1 atom name(s) do not match"), std::string::npos) << warnings[0];
  EXPECT_NE(warnings[0].find("'HW1' here, 'HX' in the topology"), std::string::npos) << warnings[0];
  EXPECT_EQ(wrong_name.atom_names[4], "HX");

  System too_few = named_system(3);
  try {
    apply_structure(too_few, frame, kData / "water2.gro", "topol.top");
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(e.line(), 2);
    EXPECT_NE(std::string(e.what()).find("6 atoms but the topology has 3"), std::string::npos) << e.what();
  }
}
