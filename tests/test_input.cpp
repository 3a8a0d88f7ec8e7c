#include <gtest/gtest.h>

#include <random>

#include "engine/input.hpp"

using namespace vimd;

namespace {

// Every pair, minimum image: what the cell search must reproduce.
std::optional<Overlap> brute_force_overlap(const Coords& x, const Box& box, double min_distance) {
  std::optional<Overlap> found;
  int pairs = 0;
  for (int i = 0; i < x.cols(); ++i)
    for (int j = i + 1; j < x.cols(); ++j) {
      const double d = box.minimum_image(x.col(i) - x.col(j)).norm();
      if (d >= min_distance) continue;
      ++pairs;
      if (!found) found = Overlap{i, j, d, 0};
    }
  if (found) found->pairs = pairs;
  return found;
}

}  // namespace

// Boxes from many cells down to one cell per direction (where neighbouring cells repeat), partly
// and fully non-periodic, with coordinates outside the box as an unwrapped trajectory has them.
TEST(Overlap, CellSearchFindsWhatAllPairsFind) {
  const double min_distance = 0.05;
  const Vec3 boxes[] = {{3.0, 3.0, 3.0}, {0.12, 0.3, 0.07}, {0.04, 0.04, 0.04}, {0.5, 0, 0.5}, {0, 0, 0}};
  std::mt19937_64 rng(7);
  for (const Vec3& length : boxes) {
    Box box;
    box.length = length;
    for (int trial = 0; trial < 40; ++trial) {
      SCOPED_TRACE(::testing::Message() << "box " << length.transpose() << " trial " << trial);
      const int n = 2 + trial;
      std::uniform_real_distribution<double> coordinate(-0.5, 1.5), offset(-0.06, 0.06);
      Coords x(3, n);
      for (int i = 0; i < n; ++i) {
        // Half the atoms near an earlier one (or one of its periodic images), so pairs straddle
        // the 0.05 nm limit and the cell walls.
        const bool near = i > 0 && rng() % 2 == 0;
        const int partner = near ? static_cast<int>(rng() % i) : 0;
        for (int k = 0; k < 3; ++k) {
          const double image = length[k] * (static_cast<int>(rng() % 3) - 1);
          x(k, i) = near ? x(k, partner) + offset(rng) + image : coordinate(rng) * (length[k] > 0 ? length[k] : 0.4);
        }
      }
      const auto expected = brute_force_overlap(x, box, min_distance);
      const auto found = find_overlap(x, box, min_distance);
      ASSERT_EQ(found.has_value(), expected.has_value());
      if (!expected) continue;
      EXPECT_EQ(found->i, expected->i);
      EXPECT_EQ(found->j, expected->j);
      EXPECT_DOUBLE_EQ(found->distance, expected->distance);
      EXPECT_EQ(found->pairs, expected->pairs);
    }
  }
}

TEST(Overlap, SeesPairsThroughThePeriodicBoundary) {
  Box box;
  box.length = Vec3(3.0, 3.0, 3.0);
  Coords x(3, 3);
  x.col(0) = Vec3(0.01, 1.0, 1.0);
  x.col(1) = Vec3(1.5, 1.5, 1.5);
  x.col(2) = Vec3(2.985, 1.0, 1.0);
  const auto found = find_overlap(x, box, 0.05);
  ASSERT_TRUE(found.has_value());
  EXPECT_EQ(found->i, 0);
  EXPECT_EQ(found->j, 2);
  EXPECT_NEAR(found->distance, 0.025, 1e-12);
  box.length = Vec3::Zero();  // not periodic: the same atoms are 2.975 nm apart
  EXPECT_FALSE(find_overlap(x, box, 0.05).has_value());
}
