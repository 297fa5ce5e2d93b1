// Shared helpers of the renderer tests: one headless context per process, constant and
// single-texel environments, and the analytic sphere seen by a pinhole camera.
#pragma once

#include <gtest/gtest.h>

#include <cmath>
#include <glm/gtc/matrix_transform.hpp>
#include <optional>

#include "arlight/common/camera.hpp"
#include "arlight/render/opencv.hpp"
#include "arlight/render/render.hpp"

namespace arlight::render::testing {

inline GlContext& context() {
  static GlContext ctx = GlContext::headless();
  return ctx;
}

inline EnvMap constant_env(Projection p, int n, glm::vec3 c) {
  const EnvLayout layout = EnvLayout::for_size(p, n);
  return EnvMap(layout, Image(layout.width(), layout.height(), c));
}

// The same map for every shininess (a constant environment convolves to itself, Alg. 4.1).
inline void set_constant_maps(Renderer& r, Projection p, glm::vec3 c) {
  const std::vector<double> s = {1, 16, 256};
  r.set_maps(s, {constant_env(p, 16, c), constant_env(p, 16, c), constant_env(p, 16, c)});
}

// A camera at distance `dist` on +Z of the scene origin, looking at it (camera_from_scene).
inline glm::dmat4 camera_on_z(double dist) {
  return glm::translate(glm::dmat4(1.0), glm::dvec3(0, 0, -dist));
}

// Where the ray through pixel (x, y) meets a sphere (centre in camera coordinates), if it does;
// also the ray's closest distance to the centre.
struct RayHit {
  double distance_to_centre;
  std::optional<glm::dvec3> point;  // camera coordinates
};

inline RayHit ray_sphere(const PinholeCamera& cam, int x, int y, glm::dvec3 centre, double r) {
  const glm::dvec3 d = cam.unproject({double(x), double(y)});
  const double along = glm::dot(centre, d);
  const double dist = glm::length(centre - along * d);
  if (dist > r) return {dist, std::nullopt};
  return {dist, (along - std::sqrt(r * r - dist * dist)) * d};
}

// A unit sphere 4 m in front of a 160x120 camera with a 40-degree field, lit by whatever the
// test sets on `r`; the scene frame is the camera's rotated frame (camera_on_z).
struct SphereScene {
  static constexpr int W = 160, H = 120;
  static constexpr double kDist = 4.0, kRadius = 1.0;

  explicit SphereScene(int rings = 48, int segments = 96)
      : sphere(make_sphere(float(kRadius), rings, segments)) {
    r.set_camera(k, camera_on_z(kDist));
  }
  GlContext& ctx = context();  // first: everything below needs it current
  Renderer r{W, H};
  CameraIntrinsics k = CameraIntrinsics::from_fov(W, H, 40.0);
  PinholeCamera cam{k};
  GpuMesh sphere;
  const glm::dvec3 centre{0, 0, -kDist};

  HdrReadback render(const Material& m) {
    r.begin_frame();
    r.draw(sphere, m, glm::mat4(1.0f));
    return r.read_hdr();
  }
  // Pixels well inside (1) / outside (0) the analytic silhouette; -1 near the edge.
  int inside(int x, int y) const {
    const double d = ray_sphere(cam, x, y, centre, kRadius).distance_to_centre;
    return d < kRadius - 0.02 ? 1 : d > kRadius + 0.02 ? 0 : -1;
  }
  // Analytic hit point on the sphere in scene coordinates (camera = scene rotation here).
  std::optional<glm::dvec3> hit(int x, int y) const {
    const RayHit h = ray_sphere(cam, x, y, centre, kRadius);
    if (!h.point) return std::nullopt;
    return *h.point - centre;
  }
};

inline glm::vec3 bgr_at(const cv::Mat& m, int x, int y) {
  const auto& p = m.at<cv::Vec3b>(y, x);
  return {float(p[2]), float(p[1]), float(p[0])};  // as RGB
}

// A camera frame of reproducible noise (so "unchanged" is a strong statement).
inline cv::Mat noise_frame(int w, int h) {
  cv::Mat m(h, w, CV_8UC3);
  std::uint32_t s = 12345;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int c = 0; c < 3; ++c) {
        s = s * 1664525u + 1013904223u;
        m.at<cv::Vec3b>(y, x)[c] = std::uint8_t(s >> 24);
      }
  return m;
}

inline float lum(glm::vec3 c) { return glm::dot(c, glm::vec3(0.299f, 0.587f, 0.114f)); }

}  // namespace arlight::render::testing
