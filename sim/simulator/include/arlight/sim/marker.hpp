// An ArUco marker (cv::aruco DICT_4X4_50) printed on a white sheet lying flat on the floor,
// for the client's marker-tracking tests: its geometry, its radiance and where it lands in a
// view. The marker frame is OpenCV aruco's (x right, y up in the marker image, z out of the
// marker); on the floor z is world +Y and the image's top edge points to world -Z.
#pragma once

#include <array>
#include <glm/vec3.hpp>
#include <optional>

#include "arlight/common/camera.hpp"
#include "arlight/common/projection.hpp"
#include "arlight/truth/truth.hpp"

namespace arlight::sim {

using recording::Pose;

struct MarkerSpec {
  int id = 0;
  double size_m = 0.2;                 // side of the black square
  glm::dvec3 centre{0.0, -1.2, -0.8};  // world point the marker is centred on
};

// Pixel rectangle [x0, x1] x [y0, y1] (inclusive), empty when x0 > x1.
struct PixelBox {
  int x0 = 0, y0 = 0, x1 = -1, y1 = -1;
  bool empty() const { return x0 > x1 || y0 > y1; }
};

class MarkerScene {
 public:
  static constexpr float kWhite = 0.8f, kBlack = 0.04f;  // diffuse albedos

  // `irradiance_mean`: the environment's cosine-weighted mean radiance over the upper
  // hemisphere (what lights a floor); the marker's radiance is albedo times it.
  MarkerScene(const MarkerSpec& spec, const glm::vec3& irradiance_mean);

  const MarkerSpec& spec() const { return spec_; }
  Pose pose() const;  // marker frame -> world
  // The black square's corners in the world, in cv::aruco's order: top-left, top-right,
  // bottom-right, bottom-left of the marker image.
  std::array<glm::dvec3, 4> corners() const;

  // Radiance of the sheet (marker plus its white quiet zone of one module) where the ray from
  // `origin` along `dir` meets it, seen from above; std::nullopt when it misses.
  std::optional<glm::vec3> hit(const glm::dvec3& origin, const glm::dvec3& dir) const;

  // The pixels of a camera at `camera` (camera -> world) the sheet may touch, clipped to the
  // image, with a pixel of margin.
  PixelBox footprint(const PinholeCamera& cam, const Pose& camera) const;

  // All four corners in front of the camera and inside the image (and the camera above the
  // floor, so it sees the printed side).
  bool visible(const PinholeCamera& cam, const Pose& camera) const;

 private:
  MarkerSpec spec_;
  glm::vec3 white_, black_;
  std::array<std::array<bool, 6>, 6> black_cell_{};  // [row][col], row 0 = the image's top
};

// The environment's cosine-weighted mean radiance over the upper hemisphere (normal +Y):
// sum L max(0, d.y) dOmega / pi over the probe's texels.
glm::vec3 upper_hemisphere_irradiance_mean(const EnvMap& env);

}  // namespace arlight::sim
