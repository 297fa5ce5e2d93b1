// What one camera frame carries besides its pixels: the vocabulary shared by sources,
// recordings, the wire protocol, the capture library and the daemon (one type for the concept).
#pragma once

#include <glm/gtc/quaternion.hpp>

namespace arlight {

struct FrameInfo {
  double timestamp = 0;                // seconds
  double exposure = 0;                 // seconds, > 0
  double gain = 1;                     // > 0; radiance = linear / (exposure * gain)
  glm::dquat orientation{1, 0, 0, 0};  // camera -> world, from the device's sensors
};

}  // namespace arlight
