// Registering another device's frames to a session's map (issue 49 §1: two phones, one room).
// Two phones' orientation frames share gravity (each accelerometer finds the same down) but not
// heading: each IMU's yaw origin is wherever it started. So a contributor's first frames are
// laid on the map at every heading about the world's +Y and compared with what the map holds
// there — the log luminance of the frame's blocks against the map's, by their correlation less
// what both owe to elevation (ceiling to floor is alike at every heading), which an unknown
// exposure or sensitivity (a factor: an offset in log) does not change — first on a coarse
// grid over all 360 degrees, then on the pixels around the best few coarse peaks.
// A heading is taken only when it explains the view well and clearly better than any other
// heading: a room with another room's frames, or a view of a wall the map has not seen, is
// refused rather than merged somewhere wrong. What is left after it (a small tilt, the heading
// to a fraction of a degree, the drift) is the feature alignment's (align.hpp).
#pragma once

#include <glm/gtc/quaternion.hpp>
#include <string>

#include "arlight/capture/capture.hpp"
#include "arlight/common/camera.hpp"
#include "linearize.hpp"
#include "map_view.hpp"

namespace arlight::capture {

struct HeadingFit {
  bool ok = false;
  double heading = 0.0;  // radians about world +Y: world = R_y(heading) * sensor orientation
  double score = -1.0;   // correlation at the heading (fine)
  double runner_up = -1.0;  // the best fine correlation around another coarse peak
  double overlap = 0.0;     // share of the frame's blocks on the measured map at the heading
  std::string why;          // when !ok
};

// The heading that lays `frame` — linearised and reduced, seen through `camera` (its reduced
// intrinsics) at the device's `sensor` orientation (camera -> its own world) — onto `map`.
HeadingFit fit_heading(const LinearFrame& frame, const PinholeCamera& camera,
                       const glm::dquat& sensor, const MapAccumulators& map,
                       const RegistrationOptions& options = {});

// The rotation by `heading` radians about world +Y.
glm::dquat heading_rotation(double heading);

}  // namespace arlight::capture
