// WorldFromMarker: the fixed rotation from the tracked marker's frame to the IMU's world frame
// (orientation.hpp says why the renderer needs it). Free of OpenCV: the browser client compiles
// it to WebAssembly with the pose filter (arlight_track_core).
#pragma once

#include <cstddef>
#include <deque>
#include <glm/gtc/quaternion.hpp>
#include <optional>

namespace arlight::track {

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

}  // namespace arlight::track
