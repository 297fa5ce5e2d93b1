#include "arlight/common/pose.hpp"

#include <cmath>
#include <numbers>

namespace arlight {

Pose compose(const Pose& a, const Pose& b) {
  return {glm::normalize(a.orientation * b.orientation), a.position + a.orientation * b.position};
}

Pose inverse(const Pose& p) {
  const glm::dquat inv = glm::conjugate(p.orientation);
  return {inv, -(inv * p.position)};
}

double angle_deg(const glm::dquat& a, const glm::dquat& b) {
  const glm::dquat r = glm::conjugate(a) * b;
  const double s = std::sqrt(r.x * r.x + r.y * r.y + r.z * r.z);
  return 2.0 * std::atan2(s, std::abs(r.w)) * 180.0 / std::numbers::pi;
}

glm::dvec3 log_map(const glm::dquat& q0) {
  const glm::dquat q = q0.w < 0 ? -q0 : q0;
  const glm::dvec3 v(q.x, q.y, q.z);
  const double s = glm::length(v);
  if (s < 1e-12) return 2.0 * v;  // first order
  return v * (2.0 * std::atan2(s, q.w) / s);
}

glm::dquat exp_map(const glm::dvec3& v) {
  const double a = glm::length(v);
  if (a < 1e-12) return glm::normalize(glm::dquat(1.0, 0.5 * v.x, 0.5 * v.y, 0.5 * v.z));
  return glm::angleAxis(a, v / a);
}

}  // namespace arlight
