// Rigid poses and rotations: the vocabulary of orientation sensors, trackers, the simulator's
// ground truth and the capture library's drift model (one type, one set of helpers).
#pragma once

#include <glm/gtc/quaternion.hpp>
#include <glm/vec3.hpp>

namespace arlight {

// A rigid pose: `orientation` rotates the frame's coordinates into the parent's (the world: +Y
// up, -Z forward), `position` is the frame's origin in the parent's coordinates (metres).
struct Pose {
  glm::dquat orientation{1, 0, 0, 0};
  glm::dvec3 position{0.0};
};

// a * b: b's frame -> a's frame -> a's parent (b expressed in a, then a in its parent).
Pose compose(const Pose& a, const Pose& b);
Pose inverse(const Pose& p);

// The angle of the rotation between two orientations, degrees (0..180; q and -q are equal),
// as 2 atan2(|v|, |w|) of the relative rotation: accurate for small angles, unlike acos, and
// independent of the quaternions' norms.
double angle_deg(const glm::dquat& a, const glm::dquat& b);

// Rotation vector (axis * angle, radians) of a unit quaternion, the shorter way round, and back.
glm::dvec3 log_map(const glm::dquat& q);
glm::dquat exp_map(const glm::dvec3& v);

}  // namespace arlight
