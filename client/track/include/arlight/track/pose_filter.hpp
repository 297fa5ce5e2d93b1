// Smoothing of tracked poses without lag: a constant-velocity alpha-beta filter whose gain
// adapts to the speed as in the One-Euro filter (Casiez, Roussel and Vogel, CHI 2012). The
// pose is predicted with the filtered velocity, then pulled towards the measurement by alpha,
// the smoothing factor of a low-pass whose cut-off rises with the speed: a still camera's
// jitter is removed (low cut-off), and because of the prediction, steady motion has no lag at
// all (a plain One-Euro filter trails a moving camera by (1 - alpha) / alpha frames' motion).
// The speed that sets the cut-off is the larger of the filtered velocity and the innovation
// (measurement minus prediction, less the expected jitter) per second, so motion starting from
// rest opens the filter at once instead of after the velocity has caught up (no lag spike).
// After a (re)start the second pose sets the velocity, so a moving camera is not lagged then
// either.
// The velocity gain is Kalata's critically damped beta = alpha^2 / (2 - alpha). Rotation is
// filtered on the manifold (body-frame rotation vectors). A gap longer than reset_after_s (a
// lost marker) restarts the filter at the next pose, so nothing is smeared across the gap.
#pragma once

#include <optional>

#include "arlight/track/pose_math.hpp"

namespace arlight::track {

struct PoseFilterOptions {
  bool enabled = true;
  // Translation: cut-off at rest (Hz) and its rise per m/s of speed.
  double min_cutoff_hz = 1.5;
  double beta_per_m = 10.0;
  // Rotation: cut-off at rest (Hz) and its rise per rad/s.
  double rot_min_cutoff_hz = 1.5;
  double rot_beta_per_rad = 3.0;
  // The tracker's jitter: innovations within it do not count as motion.
  double jitter_m = 0.003;
  double jitter_deg = 0.3;
  double reset_after_s = 0.5;
};

class PoseFilter {
 public:
  explicit PoseFilter(const PoseFilterOptions& options = {}) : o_(options) {}
  // Filters the pose observed at time t (seconds, increasing); returns the smoothed pose.
  Pose update(const Pose& raw, double t);
  void reset() { state_.reset(); }
  bool primed() const { return state_.has_value(); }
  // The filtered velocity of the position (parent-frame units per second) at the last update;
  // zero before two poses. A renderer extrapolates the position with it to the time of a frame
  // whose own pose is not measured yet.
  glm::dvec3 velocity() const { return state_ && state_->moving ? state_->velocity : glm::dvec3(0.0); }

 private:
  struct State {
    Pose pose;
    glm::dvec3 velocity{0.0};  // m/s, world (parent-frame) coordinates
    glm::dvec3 angular{0.0};   // rad/s, body coordinates
    double t = 0;
    bool moving = false;  // the velocity has been set from two poses
  };
  PoseFilterOptions o_;
  std::optional<State> state_;
};

}  // namespace arlight::track
