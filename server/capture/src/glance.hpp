// A glance at a frame before it is processed (issue 37 §1: frames that add nothing cost
// nothing). The JPEG is decoded at 1/8 of its size (1/4 in the DCT domain, where libjpeg skips
// most of the inverse transform, then 2x2 in linear radiance), and compared with the map
// averaged over blocks of the same angular size: when the frame sees nothing new and agrees
// with the map (CaptureOptions::glance_share / unchanged_bias), it is an unchanged frame without
// the full decode, alignment, exposure estimate and sampling of every texel in view.
#pragma once

#include <cstdint>
#include <glm/gtc/quaternion.hpp>
#include <glm/vec3.hpp>
#include <map>
#include <optional>
#include <span>
#include <vector>

#include "arlight/common/camera.hpp"
#include "arlight/common/projection.hpp"
#include "arlight/common/response.hpp"
#include "linearize.hpp"

namespace arlight::capture {

// The capture map's texels averaged over k x k blocks of each cube face: per block the
// solid-angle-weighted mean radiance of its measured texels, the share of its solid angle they
// cover and the brightest of them. Blocks are recomputed lazily, when read after a texel of
// theirs changed.
class BlockMap {
 public:
  // `layout` a cube map whose face k divides; `omega` its texels' solid angles (texel order).
  BlockMap(const EnvLayout& layout, int k, std::span<const double> omega);

  void touch(std::size_t texel) { dirty_[block_of(texel)] = 1; }
  void touch_all() { std::fill(dirty_.begin(), dirty_.end(), std::uint8_t(1)); }

  struct Block {
    glm::vec3 radiance{0.0f};
    float measured = 0.0f;  // share of the block's solid angle measured at all
    float peak = 0.0f;      // the largest channel of any of its texels
  };
  // The map's blocks bilinearly at direction d (within d's face, clamped at its edges): the
  // radiance and measured share interpolated, and the largest peak among the four blocks read.
  Block at(glm::dvec3 d, std::span<const float> weighted_radiance, std::span<const float> weight);

 private:
  std::size_t block_of(std::size_t texel) const;
  const Block& block(std::size_t b, std::span<const float> weighted_radiance,
                     std::span<const float> weight);

  int k_, face_, block_face_;
  EnvLayout blocks_ = EnvLayout::for_size(Projection::Cube, 1);  // one texel a block
  std::span<const double> omega_;
  std::vector<Block> values_;
  std::vector<std::uint8_t> dirty_;
};

// The glance's verdict over the frame's well-exposed pixels: `change` and `bias` as
// FrameResult's (sum |seen - held| and sum (seen - held) over sum held, luminance x solid
// angle); `sees_new` when a pixel falls where the map is not measured well.
struct GlanceVerdict {
  bool sees_new = false;
  // A clipped pixel falls where the map holds less than 0.9 x the clip floor (the capture's
  // exposure advice has to see the frame: CaptureSession's check_clipped()).
  bool clipped_unmeasured = false;
  double change = 0.0, bias = 0.0;
  int pixels = 0;        // pixels compared
  int image_pixels = 0;  // in the glance image
};

// Compares a linearised glance image (`rays` its pixels' rays) seen at `orientation` with the
// map's blocks over the image's interior (pixels of weight >= 0.9); `clip_floor` is the least
// radiance a clipped pixel of this frame proves.
GlanceVerdict glance_at_map(const LinearFrame& image, std::span<const glm::dvec3> rays,
                            const glm::dquat& orientation, BlockMap& blocks,
                            std::span<const float> weighted_radiance, std::span<const float> weight,
                            float clip_floor);

// The glances of one capture session: decodes, linearises and compares (glance_at_map()),
// keeping per glance size the map's blocks and the image's rays (undistortion is iterative).
class Glancer {
 public:
  // Frames come at the camera's size or reduced by a power of two up to `reduction`; the
  // capture reduces them by `factor` (about a texel a pixel) into `layout` (a cube map, else
  // std::invalid_argument), whose texels have solid angles `omega`.
  Glancer(const CameraIntrinsics& camera, int reduction, int factor, const EnvLayout& layout,
          std::span<const double> omega);

  // `jpeg` at 1/8 of the size it was sent at, at exposure x gain `exposure_gain` and
  // `orientation`, against the map's accumulators. Nothing when this frame cannot be glanced
  // (not a JPEG of an expected size, or blocks of its pixel size do not fit the layout).
  std::optional<GlanceVerdict> look(std::span<const std::uint8_t> jpeg,
                                    const CameraResponse& response, double exposure_gain,
                                    const glm::dquat& orientation,
                                    std::span<const float> weighted_radiance,
                                    std::span<const float> weight);
  // The map changed at `texel` / everywhere.
  void touch(std::size_t texel) {
    for (auto& [pixel, g] : sizes_) g.blocks.touch(texel);
  }
  void touch_all() {
    for (auto& [pixel, g] : sizes_) g.blocks.touch_all();
  }

 private:
  struct Size {
    BlockMap blocks;
    int width, height;
    std::vector<glm::dvec3> rays;
  };
  CameraIntrinsics camera_;
  int reduction_, factor_;
  EnvLayout layout_;
  std::span<const double> omega_;
  std::map<int, Size> sizes_;  // by camera pixels a glance pixel spans
};

}  // namespace arlight::capture
