// Rotations for tracking: the change between OpenCV's camera (x right, y down, z forward) and
// the project's (x right, y up, looking down -z; common/CONVENTIONS.md). Poses themselves and
// their algebra are common/ (arlight/common/pose.hpp). Free of OpenCV, like the pose filter and
// WorldFromMarker (arlight_track_core: the browser client compiles them).
#pragma once

#include <glm/gtc/quaternion.hpp>
#include <glm/mat3x3.hpp>
#include <glm/vec3.hpp>

#include "arlight/common/pose.hpp"

namespace arlight::track {

using arlight::angle_deg;
using arlight::compose;
using arlight::exp_map;
using arlight::inverse;
using arlight::log_map;
using arlight::Pose;

// OpenCV solvePnP's marker -> OpenCV-camera transform (rvec, tvec: x_cv = R x_marker + t) as
// the project's camera -> marker pose (orientation R^T F, position -R^T t, F = diag(1,-1,-1)).
Pose pose_from_opencv(const glm::dvec3& rvec, const glm::dvec3& tvec);

// A rotation in OpenCV camera coordinates (F R F, F = diag(1,-1,-1)) in the project's camera
// coordinates; the map is its own inverse.
glm::dmat3 flip_camera_axes(const glm::dmat3& r);

// The renderer's view matrix (scene -> camera coordinates) of a camera whose pose in the scene
// (marker) frame is `camera_in_scene`: the inverse pose as a 4x4 matrix.
glm::dmat4 view_matrix(const Pose& camera_in_scene);

}  // namespace arlight::track
