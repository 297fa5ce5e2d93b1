#include "arlight/sim/marker.hpp"

#include <algorithm>
#include <cmath>
#include <glm/geometric.hpp>
#include <glm/gtc/quaternion.hpp>
#include <numbers>
#include <opencv2/aruco.hpp>
#include <vector>

namespace arlight::sim {

MarkerScene::MarkerScene(const MarkerSpec& spec, const glm::vec3& irradiance_mean)
    : spec_(spec), white_(kWhite * irradiance_mean), black_(kBlack * irradiance_mean) {
  // One pixel per module: 4x4 data bits inside a one-module black border.
  const auto dict = cv::aruco::getPredefinedDictionary(cv::aruco::DICT_4X4_50);
  cv::Mat img;
  cv::aruco::drawMarker(dict, spec_.id, 6, img, 1);
  for (int r = 0; r < 6; ++r)
    for (int c = 0; c < 6; ++c)
      black_cell_[std::size_t(r)][std::size_t(c)] = img.at<std::uint8_t>(r, c) < 128;
}

Pose MarkerScene::pose() const {
  // Marker x = world +X, marker y (the image's up) = world -Z, marker z = world +Y: a rotation
  // of -90 degrees about X.
  return {glm::angleAxis(-0.5 * std::numbers::pi, glm::dvec3(1, 0, 0)), spec_.centre};
}

std::array<glm::dvec3, 4> MarkerScene::corners() const {
  const double h = 0.5 * spec_.size_m;
  const Pose p = pose();
  std::array<glm::dvec3, 4> out;
  const glm::dvec3 local[4] = {{-h, h, 0}, {h, h, 0}, {h, -h, 0}, {-h, -h, 0}};
  for (int i = 0; i < 4; ++i) out[std::size_t(i)] = p.orientation * local[i] + p.position;
  return out;
}

std::optional<glm::vec3> MarkerScene::hit(const glm::dvec3& origin, const glm::dvec3& dir) const {
  const glm::dvec3& c = spec_.centre;
  if (!(origin.y > c.y) || !(dir.y < 0.0)) return std::nullopt;  // only the printed side
  const glm::dvec3 p = origin + dir * ((c.y - origin.y) / dir.y);
  const double mx = p.x - c.x, my = c.z - p.z;  // marker coordinates (x right, y to -Z)
  const double half = 0.5 * spec_.size_m, module = spec_.size_m / 6.0;
  const double sheet = half + module;
  if (std::abs(mx) > sheet || std::abs(my) > sheet) return std::nullopt;
  if (std::abs(mx) >= half || std::abs(my) >= half) return white_;  // the quiet zone
  const int col = std::clamp(int(std::floor((mx + half) / module)), 0, 5);
  const int row = std::clamp(int(std::floor((half - my) / module)), 0, 5);
  return black_cell_[std::size_t(row)][std::size_t(col)] ? black_ : white_;
}

PixelBox MarkerScene::footprint(const PinholeCamera& cam, const Pose& camera) const {
  const glm::dvec3& c = spec_.centre;
  if (!(camera.position.y > c.y)) return {};
  const double s = 0.5 * spec_.size_m + spec_.size_m / 6.0;
  const glm::dquat to_camera = glm::conjugate(camera.orientation);
  std::vector<glm::dvec3> poly;
  for (const auto& [dx, dz] : {std::pair{-s, -s}, {s, -s}, {s, s}, {-s, s}})
    poly.push_back(to_camera * (c + glm::dvec3(dx, 0.0, dz) - camera.position));
  // Clip the sheet to the half-space in front of the camera (z <= -near; it looks down -z).
  const double near = 1e-6;
  std::vector<glm::dvec3> clipped;
  for (std::size_t i = 0; i < poly.size(); ++i) {
    const glm::dvec3& a = poly[i];
    const glm::dvec3& b = poly[(i + 1) % poly.size()];
    const bool ina = a.z <= -near, inb = b.z <= -near;
    if (ina) clipped.push_back(a);
    if (ina != inb) clipped.push_back(a + (b - a) * ((-near - a.z) / (b.z - a.z)));
  }
  if (clipped.empty()) return {};
  // The bounding box of the projected polygon (straight edges stay straight without lens
  // distortion, which the simulator's camera has none of).
  const CameraIntrinsics& k = cam.intrinsics();
  double x0 = 1e300, y0 = 1e300, x1 = -1e300, y1 = -1e300;
  for (const glm::dvec3& v : clipped) {
    const glm::dvec3 in_front(v.x, v.y, std::min(v.z, -near));
    const auto px = cam.project(in_front);
    if (!px) continue;
    x0 = std::min(x0, px->x), x1 = std::max(x1, px->x);
    y0 = std::min(y0, px->y), y1 = std::max(y1, px->y);
  }
  if (x0 > x1) return {};
  auto clamp_to = [](double v, int hi) { return int(std::clamp(v, -1.0, double(hi) + 1.0)); };
  PixelBox box;
  box.x0 = std::max(0, clamp_to(std::floor(x0), k.width) - 1);
  box.y0 = std::max(0, clamp_to(std::floor(y0), k.height) - 1);
  box.x1 = std::min(k.width - 1, clamp_to(std::ceil(x1), k.width) + 1);
  box.y1 = std::min(k.height - 1, clamp_to(std::ceil(y1), k.height) + 1);
  return box;
}

bool MarkerScene::visible(const PinholeCamera& cam, const Pose& camera) const {
  if (!(camera.position.y > spec_.centre.y)) return false;
  const CameraIntrinsics& k = cam.intrinsics();
  const glm::dquat to_camera = glm::conjugate(camera.orientation);
  for (const glm::dvec3& p : corners()) {
    const auto px = cam.project(to_camera * (p - camera.position));
    if (!px || px->x < -0.5 || px->y < -0.5 || px->x >= k.width - 0.5 || px->y >= k.height - 0.5)
      return false;
  }
  return true;
}

glm::vec3 upper_hemisphere_irradiance_mean(const EnvMap& env) {
  const auto table = texel_table(env.layout);
  const float* data = env.image.data();
  glm::dvec3 sum(0.0);
  for (std::size_t i = 0; i < table->size(); ++i) {
    const double w = table->y[i] * table->solid_angle[i];
    if (w <= 0.0) continue;
    const float* px = data + 3 * std::size_t(table->index[i]);
    sum += w * glm::dvec3(px[0], px[1], px[2]);
  }
  return glm::vec3(sum / std::numbers::pi);
}

}  // namespace arlight::sim
