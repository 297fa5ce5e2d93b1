#include "arlight/common/camera.hpp"

#include <cmath>
#include <glm/geometric.hpp>
#include <numbers>

namespace arlight {

namespace {

// OpenCV's distortion of normalized coordinates (x, y) = (X / Z, Y / Z).
glm::dvec2 distort(const std::array<double, 5>& d, glm::dvec2 n) {
  const double k1 = d[0], k2 = d[1], p1 = d[2], p2 = d[3], k3 = d[4];
  const double r2 = n.x * n.x + n.y * n.y;
  const double radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3));
  return {n.x * radial + 2.0 * p1 * n.x * n.y + p2 * (r2 + 2.0 * n.x * n.x),
          n.y * radial + p1 * (r2 + 2.0 * n.y * n.y) + 2.0 * p2 * n.x * n.y};
}

}  // namespace

CameraIntrinsics CameraIntrinsics::from_fov(int width, int height, double hfov_deg) {
  CameraIntrinsics k;
  k.width = width, k.height = height;
  k.fx = k.fy = 0.5 * width / std::tan(0.5 * hfov_deg * std::numbers::pi / 180.0);
  k.cx = 0.5 * width - 0.5, k.cy = 0.5 * height - 0.5;  // pixel centres are integers
  return k;
}

std::optional<glm::dvec2> PinholeCamera::project(glm::dvec3 dir) const {
  // Camera coordinates (y up, -z forward) -> OpenCV's (y down, +z forward).
  const double z = -dir.z;
  if (!(z > 0.0)) return std::nullopt;
  const glm::dvec2 d = distort(k_.distortion, {dir.x / z, -dir.y / z});
  return glm::dvec2(k_.fx * d.x + k_.cx, k_.fy * d.y + k_.cy);
}

glm::dvec3 PinholeCamera::unproject(glm::dvec2 pixel) const {
  const glm::dvec2 target((pixel.x - k_.cx) / k_.fx, (pixel.y - k_.cy) / k_.fy);
  // Fixed-point iteration n <- (target - tangential(n)) / radial(n), as cv::undistortPoints.
  const double k1 = k_.distortion[0], k2 = k_.distortion[1], p1 = k_.distortion[2],
               p2 = k_.distortion[3], k3 = k_.distortion[4];
  glm::dvec2 n = target;
  for (int i = 0; i < 100; ++i) {
    const double r2 = n.x * n.x + n.y * n.y;
    const double radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3));
    const glm::dvec2 tangential(2.0 * p1 * n.x * n.y + p2 * (r2 + 2.0 * n.x * n.x),
                                p1 * (r2 + 2.0 * n.y * n.y) + 2.0 * p2 * n.x * n.y);
    const glm::dvec2 next = (target - tangential) / radial;
    const double change = std::abs(next.x - n.x) + std::abs(next.y - n.y);
    n = next;
    if (change < 1e-15) break;
  }
  return glm::normalize(glm::dvec3(n.x, -n.y, -1.0));
}

}  // namespace arlight
