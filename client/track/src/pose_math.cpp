#include "arlight/track/pose_math.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>

namespace arlight::track {

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
