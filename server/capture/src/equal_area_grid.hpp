// The coarse grid of the fill and of the light's uncertainty: `zones` equal-area zones of
// elevation (uniform in y, Archimedes) times `sectors` sectors of azimuth, so every cell has
// the same solid angle. Cells are row-major from the bottom zone (y = -1); the azimuth is
// atan2(x, -z) + pi, so sector 0 starts behind the viewer (+Z) and turns through -X.
#pragma once

#include <algorithm>
#include <cmath>
#include <glm/vec3.hpp>
#include <numbers>

namespace arlight::capture {

struct EqualAreaGrid {
  int zones = 0, sectors = 0;
  int cell(const glm::dvec3& d) const {
    const int z = std::clamp(int(std::floor((d.y + 1.0) * 0.5 * zones)), 0, zones - 1);
    const double phi = std::atan2(d.x, -d.z) + std::numbers::pi;  // [0, 2 pi]
    const int a =
        std::clamp(int(std::floor(phi / (2.0 * std::numbers::pi) * sectors)), 0, sectors - 1);
    return z * sectors + a;
  }
  // The direction at the centre of a cell (in y and in azimuth).
  glm::dvec3 centre(int c) const {
    const double y = (c / sectors + 0.5) * 2.0 / zones - 1.0;
    const double phi = (c % sectors + 0.5) * 2.0 * std::numbers::pi / sectors - std::numbers::pi;
    const double r = std::sqrt(std::max(0.0, 1.0 - y * y));
    return {r * std::sin(phi), y, -r * std::cos(phi)};
  }
  int size() const { return zones * sectors; }
};

}  // namespace arlight::capture
