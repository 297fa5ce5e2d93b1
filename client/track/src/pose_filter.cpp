// Speed-adaptive alpha-beta filter on poses (pose_filter.hpp).
#include "arlight/track/pose_filter.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace arlight::track {

namespace {

// The exponential smoothing factor of a first-order low-pass with this cut-off at this step
// (One-Euro's alpha).
double alpha(double cutoff_hz, double dt) {
  const double tau = 1.0 / (2.0 * std::numbers::pi * cutoff_hz);
  return 1.0 / (1.0 + tau / dt);
}

// Kalata's critically damped velocity gain for a position gain a.
double beta(double a) { return a * a / (2.0 - a); }

}  // namespace

Pose PoseFilter::update(const Pose& raw, double t) {
  if (!o_.enabled) return raw;
  if (!state_ || !(t > state_->t) || t - state_->t > o_.reset_after_s) {
    state_ = State{raw, glm::dvec3(0.0), glm::dvec3(0.0), t, false};
    return raw;
  }
  State& s = *state_;
  const double dt = t - s.t;
  s.t = t;
  if (!s.moving) {  // the second pose: velocities from the step, no smoothing yet
    s.velocity = (raw.position - s.pose.position) / dt;
    s.angular = log_map(glm::conjugate(s.pose.orientation) * raw.orientation) / dt;
    s.pose = raw;
    s.moving = true;
    return raw;
  }

  // Translation: predict, then correct by the speed-dependent gain.
  const glm::dvec3 predicted = s.pose.position + s.velocity * dt;
  const glm::dvec3 r = raw.position - predicted;
  // The speed that sets the cut-off: the filtered one, or the innovation's beyond the jitter
  // when that is larger (motion starting from rest, which the velocity has not caught yet).
  const double speed =
      std::max(glm::length(s.velocity), std::max(0.0, glm::length(r) - o_.jitter_m) / dt);
  const double a = alpha(o_.min_cutoff_hz + o_.beta_per_m * speed, dt);
  s.pose.position = predicted + a * r;
  s.velocity += (beta(a) / dt) * r;

  // Rotation: the same with body-frame rotation vectors.
  const glm::dquat qp = glm::normalize(s.pose.orientation * exp_map(s.angular * dt));
  const glm::dvec3 rr = log_map(glm::conjugate(qp) * raw.orientation);
  const double jitter = o_.jitter_deg * std::numbers::pi / 180.0;
  const double spin =
      std::max(glm::length(s.angular), std::max(0.0, glm::length(rr) - jitter) / dt);
  const double ar = alpha(o_.rot_min_cutoff_hz + o_.rot_beta_per_rad * spin, dt);
  s.pose.orientation = glm::normalize(qp * exp_map(ar * rr));
  s.angular += (beta(ar) / dt) * rr;
  return s.pose;
}

}  // namespace arlight::track
