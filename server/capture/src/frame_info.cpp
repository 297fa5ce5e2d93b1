// A frame's metadata checked before anything uses it: exposure, gain and orientation.
#include <cmath>
#include <string>

#include "arlight/capture/capture.hpp"

namespace arlight::capture {

std::string check_frame_info(const FrameInfo& info) {
  if (!std::isfinite(info.exposure) || !(info.exposure > 0.0))
    return "exposure must be a positive number of seconds (got " + std::to_string(info.exposure) +
           ")";
  if (!std::isfinite(info.gain) || !(info.gain > 0.0))
    return "gain must be positive (got " + std::to_string(info.gain) + ")";
  const glm::dquat& q = info.orientation;
  if (!std::isfinite(q.w) || !std::isfinite(q.x) || !std::isfinite(q.y) || !std::isfinite(q.z))
    return "orientation is not a finite quaternion";
  const double norm = std::sqrt(q.w * q.w + q.x * q.x + q.y * q.y + q.z * q.z);
  if (std::abs(norm - 1.0) > 1e-3)
    return "orientation is not a unit quaternion (norm " + std::to_string(norm) + ")";
  return {};
}

}  // namespace arlight::capture
