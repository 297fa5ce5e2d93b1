// arlight_track: marker tracking and orientation for the thin client (client/track/README.md).
//  - MarkerTracker: ArUco marker -> camera pose in the marker (scene) frame, raw and smoothed.
//  - WorldFromMarker: phones; the rotation from the marker frame to the IMU's world frame.
//  - VisualGyro, OrientationEstimator: webcams; camera -> world orientation without an IMU.
#pragma once

#include "arlight/track/marker_tracker.hpp"
#include "arlight/track/orientation.hpp"
#include "arlight/track/pose_filter.hpp"
#include "arlight/track/pose_math.hpp"
