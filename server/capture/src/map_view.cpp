#include "map_view.hpp"

#include <algorithm>
#include <cmath>
#include <glm/geometric.hpp>

namespace arlight::capture {

namespace {

// The map's radiance at continuous texel coordinates p (texel centres at +0.5): bilinear
// over sum(w L) and sum(w), so texels without data do not darken their neighbours.
bool lookup_texel(const MapAccumulators& map, glm::dvec2 p, glm::vec3& radiance) {
  const EnvLayout& layout = map.layout;
  const int w = layout.width(), h = layout.height();
  p -= 0.5;
  const int x0 = int(std::floor(p.x)), y0 = int(std::floor(p.y));
  const float fx = float(p.x - x0), fy = float(p.y - y0);
  const bool wrap = layout.projection() == Projection::LatLong;
  // A cube map's faces are stacked: the neighbours stay on the face the point is on.
  int y_lo = 0, y_hi = h - 1;
  if (layout.projection() == Projection::Cube) {
    const int n = layout.face_size();
    y_lo = std::clamp(int(std::floor((p.y + 0.5) / n)), 0, 5) * n;
    y_hi = y_lo + n - 1;
  }
  glm::vec3 sum_wl(0.0f);
  float sum_w = 0.0f;
  for (int dy = 0; dy < 2; ++dy)
    for (int dx = 0; dx < 2; ++dx) {
      const int x = wrap ? (x0 + dx + w) % w : std::clamp(x0 + dx, 0, w - 1);
      const int y = std::clamp(y0 + dy, y_lo, y_hi);
      const float f = (dx ? fx : 1.0f - fx) * (dy ? fy : 1.0f - fy);
      const std::size_t i = std::size_t(y) * w + x;
      const float* q = &map.weighted_radiance[3 * i];
      sum_wl += f * glm::vec3(q[0], q[1], q[2]);
      sum_w += f * map.weight[i];
    }
  if (!(sum_w > 0.0f)) return false;
  radiance = sum_wl / sum_w;
  return true;
}

// Cube maps: the nearest texel (faces do not continue across the stored image).
bool lookup_nearest(const MapAccumulators& map, const glm::dvec3& dir, glm::vec3& radiance) {
  const glm::ivec2 t = map.layout.dir_to_texel(dir);
  const std::size_t i = std::size_t(t.y) * map.layout.width() + t.x;
  if (!(map.weight[i] > 0.0f)) return false;
  radiance = glm::vec3(map.weighted_radiance[3 * i], map.weighted_radiance[3 * i + 1],
                       map.weighted_radiance[3 * i + 2]) /
             map.weight[i];
  return true;
}

}  // namespace

MapView::MapView(const PinholeCamera& camera, const CameraResponse& response)
    : width_(camera.intrinsics().width), height_(camera.intrinsics().height) {
  rays_.resize(std::size_t(width_) * height_);
  for (int y = 0; y < height_; ++y)
    for (int x = 0; x < width_; ++x) rays_[std::size_t(y) * width_ + x] = camera.unproject({x, y});
  for (std::size_t i = 0; i < gray_code_.size(); ++i) {
    const double t = double(i) / double(gray_code_.size() - 1);
    gray_code_[i] = std::uint8_t(std::lround(255.0 * response.encode(float(t * t), 1)));
  }
}

void MapView::render(const MapAccumulators& map, const glm::dquat& orientation,
                     double exposure_gain, cv::Mat& gray, cv::Mat& mask) const {
  const EnvLayout& layout = map.layout;
  const int w = width_, h = height_;
  gray.create(h, w, CV_8U);
  mask.create(h, w, CV_8U);
  const glm::dmat3 rot = glm::mat3_cast(orientation);
  const auto texel_of = [&](int x, int y) {
    return layout.uv_to_pixel(layout.dir_to_uv(rot * rays_[std::size_t(y) * w + x]));
  };
  constexpr int kStep = 4;
  const int gw = (w - 1) / kStep + 2, gh = (h - 1) / kStep + 2;
  std::vector<glm::dvec2> grid(std::size_t(gw) * gh);
  for (int gy = 0; gy < gh; ++gy)
    for (int gx = 0; gx < gw; ++gx)
      grid[std::size_t(gy) * gw + gx] =
          texel_of(std::min(gx * kStep, w - 1), std::min(gy * kStep, h - 1));
  const bool cube = layout.projection() == Projection::Cube;
  const double seam = 0.1 * std::max(layout.width(), layout.height());
  const float top = float(gray_code_.size() - 1);
  for (int gy = 0; gy + 1 < gh; ++gy)
    for (int gx = 0; gx + 1 < gw; ++gx) {
      const glm::dvec2 c00 = grid[std::size_t(gy) * gw + gx],
                       c10 = grid[std::size_t(gy) * gw + gx + 1],
                       c01 = grid[std::size_t(gy + 1) * gw + gx],
                       c11 = grid[std::size_t(gy + 1) * gw + gx + 1];
      const double spread =
          std::max({glm::length(c10 - c00), glm::length(c01 - c00), glm::length(c11 - c00)});
      const bool exact = cube || spread > seam;
      const int x_end = std::min(w, (gx + 1) * kStep), y_end = std::min(h, (gy + 1) * kStep);
      const double sx = double(std::min((gx + 1) * kStep, w - 1) - gx * kStep);
      const double sy = double(std::min((gy + 1) * kStep, h - 1) - gy * kStep);
      for (int y = gy * kStep; y < y_end; ++y) {
        auto* g = gray.ptr<std::uint8_t>(y);
        auto* m = mask.ptr<std::uint8_t>(y);
        const double ty = sy > 0 ? (y - gy * kStep) / sy : 0.0;
        for (int x = gx * kStep; x < x_end; ++x) {
          glm::dvec2 p;
          if (exact) {
            p = texel_of(x, y);
          } else {
            const double tx = sx > 0 ? (x - gx * kStep) / sx : 0.0;
            p = (1 - ty) * ((1 - tx) * c00 + tx * c10) + ty * ((1 - tx) * c01 + tx * c11);
          }
          glm::vec3 l;
          const bool seen = cube ? lookup_nearest(map, rot * rays_[std::size_t(y) * w + x], l)
                                 : lookup_texel(map, p, l);
          if (!seen) {
            g[x] = 0, m[x] = 0;
            continue;
          }
          const float lum = luminance(l) * float(exposure_gain);
          g[x] = gray_code_[std::size_t(std::sqrt(std::clamp(lum, 0.0f, 1.0f)) * top + 0.5f)];
          m[x] = 255;
        }
      }
    }
}

}  // namespace arlight::capture
