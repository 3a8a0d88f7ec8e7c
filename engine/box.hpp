#pragma once
// Rectangular periodic box; a zero length means "not periodic in that direction".
#include <cmath>

#include "engine/types.hpp"

namespace vimd {

struct Box {
  Vec3 length = Vec3::Zero();  // nm

  bool periodic() const { return length.minCoeff() > 0; }
  double volume() const { return length.prod(); }

  // Minimum-image difference vector. Positions are never wrapped inside a step, so every
  // pair difference goes through here.
  Vec3 minimum_image(Vec3 d) const {
    // Most vectors asked about (bonds) are short: the division only where an image can be nearer.
    for (int k = 0; k < 3; ++k)
      if (length[k] > 0 && std::abs(d[k]) > 0.5 * length[k]) d[k] -= length[k] * std::nearbyint(d[k] / length[k]);
    return d;
  }
};

}  // namespace vimd
