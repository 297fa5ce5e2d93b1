// The captured map as a camera would see it (thesis ch. 3, Kán's alignment): rendered into the
// alignment camera at a predicted orientation, 8-bit gray through the frame's exposure and the
// camera response, so corners of the map can be followed into the frame.
#pragma once

#include <array>
#include <cstdint>
#include <glm/gtc/quaternion.hpp>
#include <opencv2/core/mat.hpp>
#include <span>
#include <vector>

#include "arlight/common/camera.hpp"
#include "arlight/common/projection.hpp"
#include "arlight/common/response.hpp"

namespace arlight::capture {

// A capture's accumulators in `layout`'s texel order: sum(w L) (RGB) and sum(w) per texel.
struct MapAccumulators {
  const EnvLayout& layout;
  std::span<const float> weighted_radiance;
  std::span<const float> weight;
};

class MapView {
 public:
  // For frames of `camera` whose codes follow `response`.
  MapView(const PinholeCamera& camera, const CameraResponse& response);

  // The map rendered at `orientation` (camera -> world) for a frame at exposure x gain
  // `exposure_gain`: `gray` its 8-bit codes, `mask` 255 where the map has data. Texel
  // coordinates are computed exactly on a grid of every 4th pixel and interpolated in between,
  // except in cells that straddle a seam of the projection (lat-long wrap, the angle map's back
  // pole) and on cube maps, where every pixel is computed.
  void render(const MapAccumulators& map, const glm::dquat& orientation, double exposure_gain,
              cv::Mat& gray, cv::Mat& mask) const;

 private:
  int width_, height_;
  std::vector<glm::dvec3> rays_;               // the camera ray of each pixel
  std::array<std::uint8_t, 4096> gray_code_{};  // linear [0, 1] (sqrt-spaced) -> 8-bit code
};

}  // namespace arlight::capture
