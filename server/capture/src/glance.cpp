#include "glance.hpp"

#include <algorithm>
#include <cmath>
#include <glm/geometric.hpp>
#include <glm/mat3x3.hpp>
#include <stdexcept>

#include "arlight/common/image.hpp"
#include "jpeg_decode.hpp"

namespace arlight::capture {

BlockMap::BlockMap(const EnvLayout& layout, int k, std::span<const double> omega)
    : k_(k), face_(layout.face_size()), omega_(omega) {
  if (layout.projection() != Projection::Cube || k < 1 || layout.face_size() % k != 0 ||
      omega.size() != layout.texel_count())
    throw std::invalid_argument("BlockMap: a cube map whose face " + std::to_string(k) +
                                " divides, with every texel's solid angle, expected");
  block_face_ = face_ / k;
  blocks_ = EnvLayout::for_size(Projection::Cube, block_face_);
  values_.assign(blocks_.texel_count(), Block{});
  dirty_.assign(blocks_.texel_count(), 1);
}

std::size_t BlockMap::block_of(std::size_t texel) const {
  // Stacked faces: texel (x, y) of a width-face_ image; block (x / k, y / k).
  const std::size_t x = texel % std::size_t(face_), y = texel / std::size_t(face_);
  return (y / std::size_t(k_)) * std::size_t(block_face_) + x / std::size_t(k_);
}

const BlockMap::Block& BlockMap::block(std::size_t b, std::span<const float> weighted_radiance,
                                       std::span<const float> weight) {
  Block& out = values_[b];
  if (!dirty_[b]) return out;
  dirty_[b] = 0;
  const std::size_t bx = b % std::size_t(block_face_), by = b / std::size_t(block_face_);
  glm::dvec3 sum(0.0);
  double seen = 0.0, all = 0.0;
  float peak = 0.0f;
  for (std::size_t y = by * k_; y < (by + 1) * k_; ++y)
    for (std::size_t x = bx * k_; x < (bx + 1) * k_; ++x) {
      const std::size_t t = y * std::size_t(face_) + x;
      all += omega_[t];
      const float w = weight[t];
      if (!(w > 0.0f)) continue;
      const float* p = &weighted_radiance[3 * t];
      const glm::vec3 l(p[0] / w, p[1] / w, p[2] / w);
      sum += omega_[t] * glm::dvec3(l);
      seen += omega_[t];
      peak = std::max({peak, l.x, l.y, l.z});
    }
  out.radiance = seen > 0.0 ? glm::vec3(sum / seen) : glm::vec3(0.0f);
  out.measured = all > 0.0 ? float(seen / all) : 0.0f;
  out.peak = peak;
  return out;
}

BlockMap::Block BlockMap::at(glm::dvec3 d, std::span<const float> weighted_radiance,
                             std::span<const float> weight) {
  const glm::dvec2 uv = blocks_.dir_to_uv(d);
  const int face = std::clamp(EnvLayout::cube_face_of_direction(d), 0, 5);
  // Block-centre coordinates within the face, clamped so the four reads stay on it.
  const double fx = std::clamp(uv.x * block_face_ - 0.5, 0.0, block_face_ - 1.0);
  const double fy =
      std::clamp(uv.y * 6.0 * block_face_ - 0.5 - face * block_face_, 0.0, block_face_ - 1.0);
  const int x0 = std::min(int(fx), block_face_ - 1), y0 = std::min(int(fy), block_face_ - 1);
  const int x1 = std::min(x0 + 1, block_face_ - 1), y1 = std::min(y0 + 1, block_face_ - 1);
  const float ax = float(fx - x0), ay = float(fy - y0);
  Block out;
  const int xs[2] = {x0, x1}, ys[2] = {y0, y1};
  const float wx[2] = {1.0f - ax, ax}, wy[2] = {1.0f - ay, ay};
  for (int j = 0; j < 2; ++j)
    for (int i = 0; i < 2; ++i) {
      const std::size_t b =
          std::size_t(face * block_face_ + ys[j]) * std::size_t(block_face_) + std::size_t(xs[i]);
      const Block& v = block(b, weighted_radiance, weight);
      out.radiance += wx[i] * wy[j] * v.radiance;
      out.measured += wx[i] * wy[j] * v.measured;
      out.peak = std::max(out.peak, v.peak);
    }
  return out;
}

namespace {

// `f`'s weighted radiance and weight filtered by [1 2 1] / 4 along each axis (edges clamped):
// the tent the blocks' bilinear interpolation puts on the map side, put on the image too.
LinearFrame tent_blurred(const LinearFrame& f) {
  LinearFrame out = f;
  const int w = f.width, h = f.height;
  auto pass = [&](const std::vector<float>& from, std::vector<float>& to, int channels, int dx,
                  int dy) {
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        const int xa = std::clamp(x - dx, 0, w - 1), ya = std::clamp(y - dy, 0, h - 1);
        const int xb = std::clamp(x + dx, 0, w - 1), yb = std::clamp(y + dy, 0, h - 1);
        for (int c = 0; c < channels; ++c) {
          const auto at = [&](int px, int py) {
            return from[(std::size_t(py) * std::size_t(w) + std::size_t(px)) * channels + c];
          };
          to[(std::size_t(y) * std::size_t(w) + std::size_t(x)) * channels + c] =
              0.25f * at(xa, ya) + 0.5f * at(x, y) + 0.25f * at(xb, yb);
        }
      }
  };
  std::vector<float> tmp_r(f.weighted_radiance.size()), tmp_w(f.weight.size());
  pass(f.weighted_radiance, tmp_r, 3, 1, 0), pass(tmp_r, out.weighted_radiance, 3, 0, 1);
  pass(f.weight, tmp_w, 1, 1, 0), pass(tmp_w, out.weight, 1, 0, 1);
  return out;
}

}  // namespace

GlanceVerdict glance_at_map(const LinearFrame& sharp, std::span<const glm::dvec3> rays,
                            const glm::dquat& orientation, BlockMap& blocks,
                            std::span<const float> weighted_radiance, std::span<const float> weight,
                            float clip_floor) {
  // A block must be measured nearly whole: a frame that would measure texels for the first
  // time is never unchanged.
  constexpr float kMeasured = 0.95f;
  // Only pixels weighing this much are looked at: the frame's middle, clear of the border's
  // ramp (where a frame adds little) and of clipping and black.
  constexpr float kInterior = 0.9f;
  GlanceVerdict v;
  const LinearFrame image = tent_blurred(sharp);
  v.image_pixels = image.width * image.height;
  if (rays.size() != image.weight.size())
    throw std::invalid_argument("glance: " + std::to_string(rays.size()) + " rays for " +
                                std::to_string(image.weight.size()) + " pixels");
  const glm::dmat3 rotation = glm::mat3_cast(orientation);
  double differ = 0.0, bias = 0.0, held_sum = 0.0;
  for (int y = 0; y < image.height; ++y)
    for (int x = 0; x < image.width; ++x) {
      const std::size_t i = std::size_t(y) * std::size_t(image.width) + std::size_t(x);
      // Pixels in the border's ramp (and clipped ones) are left out: the test is the
      // well-exposed middle of the frame.
      const float sw = image.weight[i];
      const bool clipped = sharp.clipped[i] >= 0.25f;
      if (!clipped && !(sw >= kInterior)) continue;
      const glm::dvec3& ray = rays[i];
      const BlockMap::Block held = blocks.at(rotation * ray, weighted_radiance, weight);
      // As check_clipped(): a pixel a quarter clipped or more proves its texels hold at least
      // the clip floor; the frame must be processed where the map holds less (0.9 x).
      if (clipped && !(held.peak >= 0.9f * clip_floor)) {
        v.clipped_unmeasured = true;
        return v;
      }
      if (!(sw >= kInterior)) continue;
      if (held.measured < kMeasured) {
        v.sees_new = true;
        return v;
      }
      // Next to what the frame sees clipped, the block's mean holds radiance the frame cannot
      // measure: the clip rule above speaks for those pixels.
      if (sharp.clipped[i] > 0.0f || held.peak >= clip_floor) continue;
      const float* p = &image.weighted_radiance[3 * i];
      const double seen = luminance(p[0] / sw, p[1] / sw, p[2] / sw);
      const double map = luminance(held.radiance.x, held.radiance.y, held.radiance.z);
      // A pixel's solid angle falls as cos^3 of its angle off the axis (ray is unit, z < 0).
      const double cos_axis = std::abs(ray.z);
      const double omega = cos_axis * cos_axis * cos_axis;
      differ += std::abs(seen - map) * omega;
      bias += (seen - map) * omega;
      held_sum += map * omega;
      ++v.pixels;
    }
  if (held_sum > 0.0) v.change = differ / held_sum, v.bias = bias / held_sum;
  return v;
}

Glancer::Glancer(const CameraIntrinsics& camera, int reduction, int factor, const EnvLayout& layout,
                 std::span<const double> omega)
    : camera_(camera), reduction_(reduction), factor_(factor), layout_(layout), omega_(omega) {
  if (layout.projection() != Projection::Cube)
    throw std::invalid_argument("glance: the map's blocks need a cube map");
}

std::optional<GlanceVerdict> Glancer::look(std::span<const std::uint8_t> jpeg,
                                           const CameraResponse& response, double exposure_gain,
                                           const glm::dquat& orientation,
                                           std::span<const float> weighted_radiance,
                                           std::span<const float> weight) {
  // Decoded at 1/4 in the DCT domain and reduced 2x2 more in linear radiance: codes averaged
  // over 8x8 pixels read up to 3 % dark where a textured room's codes vary (the response is
  // convex), more than the test's 0.5 % bias allows.
  std::vector<JpegSize> sizes;
  for (int k = 1; k <= reduction_; k *= 2)
    sizes.push_back({.width = camera_.width / k, .height = camera_.height / k, .scale = 4});
  std::size_t which = 0;
  std::string why;
  const cv::Mat image = decode_jpeg_bgr(jpeg, sizes, which, why);
  const int pixel = 8 << which;  // camera pixels a glance pixel spans
  // A glance pixel spans k x k texels (about): blocks of k must tile the cube's faces.
  if (image.empty() || pixel % factor_ != 0) return std::nullopt;
  const int k = pixel / factor_;
  if (k < 2 || layout_.face_size() % k != 0) return std::nullopt;
  auto it = sizes_.find(pixel);
  if (it == sizes_.end()) {
    const CameraIntrinsics glance_camera = reduced_intrinsics(camera_, pixel);
    const PinholeCamera pinhole(glance_camera);
    std::vector<glm::dvec3> rays;
    for (int y = 0; y < glance_camera.height; ++y)
      for (int x = 0; x < glance_camera.width; ++x) rays.push_back(pinhole.unproject({x, y}));
    it = sizes_
             .emplace(pixel, Size{BlockMap(layout_, k, omega_), glance_camera.width,
                                  glance_camera.height, std::move(rays)})
             .first;
  }
  Size& g = it->second;
  if ((image.cols + 1) / 2 != g.width || (image.rows + 1) / 2 != g.height) return std::nullopt;
  const LinearFrame frame = linearize(image, response, exposure_gain, 2);
  // Clipped pixels weigh next to nothing in the test; where the map does not hold what they
  // prove yet, the exposure advice must see the frame (CaptureSession's check_clipped()).
  return glance_at_map(frame, g.rays, orientation, g.blocks, weighted_radiance, weight,
                       clip_level(response) / float(exposure_gain));
}

}  // namespace arlight::capture
