// Orientation for lighting: the lighting daemon's maps live in the world frame (+Y up) that the
// device's orientations define, while the tracker places the virtual scene in the marker's
// frame. The renderer therefore needs world_from_marker to rotate its environment lookups.
//  - A phone has an IMU: WorldFromMarker estimates that fixed rotation from the IMU's
//    camera -> world orientation and the tracker's camera -> marker pose, frame after frame.
//  - A webcam has none: VisualGyro measures the rotation between consecutive frames from the
//    image, and OrientationEstimator produces camera -> world orientations in a world frame
//    defined by the marker (kWebcamWorldFromMarker), anchored while the marker is seen and
//    integrated by the visual gyro between sightings.
#pragma once

#include <cstddef>
#include <deque>
#include <memory>
#include <opencv2/core/mat.hpp>
#include <optional>
#include <string>

#include "arlight/common/camera.hpp"
#include "arlight/track/marker_tracker.hpp"
#include "arlight/track/pose_math.hpp"
#include "arlight/track/world_from_marker.hpp"

namespace arlight::track {

// ---- VisualGyro (webcams) ----

// The nearest rotation to a 3x3 matrix (SVD, det +1), as a unit quaternion.
glm::dquat nearest_rotation(const glm::dmat3& m);


struct VisualGyroOptions {
  int max_features = 200;
  double feature_quality = 0.005;  // goodFeaturesToTrack's qualityLevel
  double min_distance_px = 10;
  int lk_window = 15;
  int lk_levels = 3;
  double max_fb_error_px = 0.5;  // forward-backward optical flow consistency
  double ransac_px = 1.0;        // homography RANSAC threshold
  int min_inliers = 25;
  // Frames wider than this are downscaled for the gyro (intrinsics scaled alike); 0: never.
  int max_width = 640;
};

struct GyroStep {
  bool ok = false;
  std::string status;  // why not ok, or "ok"
  // Previous camera <- current camera (project convention): world_from_current =
  // world_from_previous * delta.
  glm::dquat delta{1, 0, 0, 0};
  int tracked = 0;          // features followed by optical flow
  int inliers = 0;          // agreeing with the rotation
  double residual_px = 0;   // RMS angular residual of the inliers, in pixels at the focal length
};

// Rotation between consecutive frames from sparse optical flow: goodFeaturesToTrack +
// pyramidal Lucas-Kanade (forward-backward checked) -> homography with RANSAC on undistorted
// normalised points (so H is K^-1 H_px K, a pure rotation for a rotating camera or a distant
// scene) -> the rotation refined by Kabsch/SVD on the inliers' bearing vectors, which is the
// orthonormalised least-squares version of R = K^-1 H K.
class VisualGyro {
 public:
  explicit VisualGyro(const CameraIntrinsics& camera, const VisualGyroOptions& options = {});
  ~VisualGyro();
  VisualGyro(VisualGyro&&) noexcept;
  VisualGyro& operator=(VisualGyro&&) noexcept;
  // The next frame (8-bit BGR or gray); the first frame after construction or reset() only
  // primes the gyro (ok = false, "first frame").
  GyroStep update(const cv::Mat& image);
  void reset();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// ---- OrientationEstimator (webcams) ----

// A webcam's world frame: the marker frame re-expressed with +Y up along the marker's normal
// (marker z), -Z along the marker image's top edge (marker y), +X = marker x. For a marker
// lying on a floor or table this is gravity-aligned (+Y up) like a phone's world; the
// simulator's marker has exactly this pose in its world. A rotation of -90 degrees about x.
glm::dquat webcam_world_from_marker();

struct OrientationOptions {
  // Complementary filter: while the marker is seen, the gyro's prediction is pulled this far
  // towards the marker's orientation each frame (0..1); a disagreement above snap_deg snaps.
  double marker_weight = 0.3;
  double snap_deg = 5.0;
  VisualGyroOptions gyro;
};

struct OrientationEstimate {
  // Camera -> world (webcam world above); std::nullopt until the marker was seen once.
  std::optional<glm::dquat> orientation;
  enum class Source { None, Marker, Gyro, Stale } source = Source::None;
  double since_marker_s = 0;  // time since the last marker fix
  GyroStep gyro;              // this frame's visual-gyro step
};

class OrientationEstimator {
 public:
  explicit OrientationEstimator(const CameraIntrinsics& camera,
                                const OrientationOptions& options = {});
  // One frame and, if the tracker ran on it, its result (only `tracked` results are used).
  OrientationEstimate update(const cv::Mat& image, double timestamp,
                             const TrackResult* marker = nullptr);
  void reset();

 private:
  OrientationOptions o_;
  VisualGyro gyro_;
  std::optional<glm::dquat> q_;
  double last_fix_ = 0;
};

}  // namespace arlight::track
