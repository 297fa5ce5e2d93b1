#include "arlight/sim/guided_motion.hpp"

#include <algorithm>
#include <cmath>
#include <glm/geometric.hpp>
#include <numbers>

#include "arlight/common/error.hpp"
#include "arlight/sim/trajectory.hpp"
#include "noise.hpp"

namespace arlight::sim {

namespace {

constexpr double kDeg = std::numbers::pi / 180.0;
constexpr double kStep = 1.0 / 240.0;

double angle_deg(const glm::dvec3& a, const glm::dvec3& b) {
  return std::acos(std::clamp(glm::dot(a, b), -1.0, 1.0)) / kDeg;
}

glm::dvec3 unit_or_throw(const glm::dvec3& d, const char* what) {
  const double n = glm::length(d);
  if (!(n > 1e-9) || !std::isfinite(n)) throw InputError(std::string(what) + ": not a direction");
  return d / n;
}

}  // namespace

GuidedMotion::GuidedMotion(const GuidedMotionParams& params) : p_(params) {
  if (!(p_.max_rate_deg_s > 0) || !(p_.accel_deg_s2 > 0) || !(p_.reaction_s >= 0) ||
      !(p_.arrived_deg > 0) || !(p_.tremor >= 0))
    throw InputError("guided motion: rates, acceleration and the arrival angle must be > 0, "
                     "reaction and tremor >= 0");
  view_ = unit_or_throw(p_.start, "guided motion start");
}

void GuidedMotion::propose(const glm::dvec3& direction, double time) {
  const glm::dvec3 d = unit_or_throw(direction, "proposed view");
  const glm::dvec3& followed = pending_ ? *pending_ : (target_ ? *target_ : view_);
  if ((pending_ || target_) && angle_deg(d, followed) < p_.arrived_deg) return;
  pending_ = d;
  pending_at_ = time + p_.reaction_s;
}

void GuidedMotion::advance(double dt) {
  if (pending_ && time_ >= pending_at_) {
    target_ = pending_;
    pending_.reset();
  }
  if (!target_) {
    rate_ = 0;
    return;
  }
  const double left = angle_deg(view_, *target_);
  // Slow down in time to stop at the target: the rate whose braking distance is what is left.
  const double stop_rate = std::sqrt(2.0 * p_.accel_deg_s2 * std::max(0.0, left - 0.5 * p_.arrived_deg));
  const double want = std::min(p_.max_rate_deg_s, stop_rate);
  rate_ = want > rate_ ? std::min(want, rate_ + p_.accel_deg_s2 * dt)
                       : std::max(want, rate_ - p_.accel_deg_s2 * dt);
  const double turn = std::min(left, rate_ * dt);
  if (left < 1e-9) return;
  // Turn along the great circle from view_ to the target (the target's part orthogonal to it).
  glm::dvec3 axis = *target_ - glm::dot(*target_, view_) * view_;
  if (glm::length(axis) < 1e-9) {  // the target is right behind: turn over the horizontal
    axis = glm::cross(view_, glm::dvec3(0, 1, 0));
    if (glm::length(axis) < 1e-9) axis = glm::dvec3(1, 0, 0);
  }
  axis = glm::normalize(axis);
  const double a = turn * kDeg;
  view_ = glm::normalize(std::cos(a) * view_ + std::sin(a) * axis);
}

glm::dquat GuidedMotion::at(double time) {
  while (time_ < time - 1e-12) {
    const double dt = std::min(kStep, time - time_);
    advance(dt);
    time_ += dt;
  }
  // Upright: yaw and pitch of the view, then the tremor on top (as the handheld path).
  const double yaw = std::atan2(-view_.x, -view_.z) / kDeg;
  const double pitch = std::asin(std::clamp(view_.y, -1.0, 1.0)) / kDeg;
  const double x = time_ / kTremorKnotSeconds;
  const std::size_t need = std::size_t(std::ceil(x)) + 4;
  for (int a = 0; a < 3; ++a)
    while (jitter_[a].size() < need)
      jitter_[a].push_back(kTremorDeg[a] * normal(hash64(p_.seed, Stream::HandheldJitter,
                                                         jitter_[a].size(), a)));
  const double t = p_.tremor;
  return yaw_pitch_roll((yaw + t * smooth_knots(jitter_[0], x)) * kDeg,
                        std::clamp(pitch + t * smooth_knots(jitter_[1], x), -90.0, 90.0) * kDeg,
                        t * smooth_knots(jitter_[2], x) * kDeg);
}

}  // namespace arlight::sim
