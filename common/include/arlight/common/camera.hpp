// The pinhole camera with OpenCV's radial-tangential distortion, between the project's camera
// coordinates (x right, y up, looking down -z; common/CONVENTIONS.md) and pixels in OpenCV's
// convention (u right, v down, integer coordinates at pixel centres).
#pragma once

#include <array>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>
#include <optional>

namespace arlight {

struct CameraIntrinsics {
  int width = 0, height = 0;
  double fx = 0, fy = 0, cx = 0, cy = 0;  // pixels
  std::array<double, 5> distortion{};     // OpenCV's k1, k2, p1, p2, k3

  // An undistorted camera of the given size whose horizontal field of view is hfov_deg,
  // principal point at the image centre, square pixels.
  static CameraIntrinsics from_fov(int width, int height, double hfov_deg);
};

class PinholeCamera {
 public:
  explicit PinholeCamera(const CameraIntrinsics& k) : k_(k) {}
  const CameraIntrinsics& intrinsics() const { return k_; }

  // Pixel of a direction in camera coordinates (need not be unit); std::nullopt when it is not
  // in front of the camera. The pixel may lie outside the image.
  std::optional<glm::dvec2> project(glm::dvec3 dir) const;

  // Unit direction in camera coordinates of a pixel, undistorted iteratively (OpenCV's
  // undistortPoints scheme, to 1e-12 in normalized coordinates for realistic distortion).
  glm::dvec3 unproject(glm::dvec2 pixel) const;

 private:
  CameraIntrinsics k_;
};

}  // namespace arlight
