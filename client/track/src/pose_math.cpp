#include "arlight/track/pose_math.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>

namespace arlight::track {

Pose compose(const Pose& a, const Pose& b) {
  return {glm::normalize(a.orientation * b.orientation), a.position + a.orientation * b.position};
}

Pose inverse(const Pose& p) {
  const glm::dquat inv = glm::conjugate(p.orientation);
  return {inv, -(inv * p.position)};
}

double angle_deg(const glm::dquat& a, const glm::dquat& b) {
  // 2 atan2(|v|, |w|) of the relative rotation: accurate for small angles, unlike acos.
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

glm::dquat nearest_rotation(const glm::dmat3& m) {
  cv::Matx33d a;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) a(r, c) = m[c][r];  // glm is column-major
  cv::Matx33d u, vt;
  cv::Matx31d w;
  cv::SVD::compute(a, w, u, vt);
  cv::Matx33d d = cv::Matx33d::eye();
  if (cv::determinant(u * vt) < 0) d(2, 2) = -1;
  const cv::Matx33d r = u * d * vt;
  glm::dmat3 g;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) g[j][i] = r(i, j);
  return glm::normalize(glm::quat_cast(g));
}

glm::dmat4 view_matrix(const Pose& camera_in_scene) {
  const Pose inv = inverse(camera_in_scene);
  glm::dmat4 m = glm::mat4_cast(inv.orientation);
  m[3] = glm::dvec4(inv.position, 1.0);
  return m;
}

glm::dmat3 flip_camera_axes(const glm::dmat3& r) {
  // F R F with F = diag(1, -1, -1): negate the entries where exactly one of row and column is
  // y or z.
  glm::dmat3 out = r;
  for (int c = 0; c < 3; ++c)
    for (int row = 0; row < 3; ++row)
      if ((c == 0) != (row == 0)) out[c][row] = -r[c][row];
  return out;
}

Pose pose_from_opencv(const glm::dvec3& rvec, const glm::dvec3& tvec) {
  cv::Matx33d r;
  cv::Rodrigues(cv::Vec3d(rvec.x, rvec.y, rvec.z), r);
  glm::dmat3 rt;  // R^T, column-major: column c of R^T is row c of R
  for (int c = 0; c < 3; ++c)
    for (int row = 0; row < 3; ++row) rt[c][row] = r(c, row);
  const glm::dvec3 t(tvec.x, tvec.y, tvec.z);
  // x_marker = R^T (x_cv - t) and x_cv = F x_ours: orientation R^T F (columns 1, 2 negated).
  glm::dmat3 o = rt;
  o[1] = -o[1];
  o[2] = -o[2];
  return {glm::normalize(glm::quat_cast(o)), -(rt * t)};
}

}  // namespace arlight::track
