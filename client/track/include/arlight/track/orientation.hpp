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

#include "arlight/camera.hpp"
#include "arlight/track/marker_tracker.hpp"
#include "arlight/track/pose_math.hpp"

namespace arlight::track {

// ---- WorldFromMarker (phones) ----

struct WorldFromMarkerOptions {
  double window_s = 2.0;          // samples older than this (before the newest) are dropped
  std::size_t max_samples = 120;  // and at most this many are kept
  std::size_t min_samples = 3;    // no estimate before this many
  // A sample is an outlier when its angle to the robust centre exceeds
  // max(outlier_min_deg, outlier_mads * 1.4826 * median angle).
  double outlier_min_deg = 1.0;
  double outlier_mads = 3.0;
};

// Robust running average of R_world_cam * R_cam_marker over recent frames. The IMU's heading
// drifts slowly (protocol/RECORDING.md, gyro_drift), so a finite window lets the estimate
// follow it.
class WorldFromMarker {
 public:
  explicit WorldFromMarker(const WorldFromMarkerOptions& options = {}) : o_(options) {}
  // One frame: camera -> world from the IMU, camera -> marker from the tracker.
  void add(double timestamp, const glm::dquat& world_from_camera,
           const glm::dquat& marker_from_camera);
  // Marker -> world rotation; std::nullopt until min_samples frames were added.
  std::optional<glm::dquat> world_from_marker() const { return estimate_; }
  std::size_t samples() const { return samples_.size(); }
  std::size_t inliers() const { return inliers_; }
  double spread_deg() const { return spread_deg_; }  // median angle of the samples to the estimate
  void reset();

 private:
  struct Sample {
    double t;
    glm::dquat q;
  };
  void estimate();
  WorldFromMarkerOptions o_;
  std::deque<Sample> samples_;
  std::optional<glm::dquat> estimate_;
  std::size_t inliers_ = 0;
  double spread_deg_ = 0;
};

// ---- VisualGyro (webcams) ----

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
