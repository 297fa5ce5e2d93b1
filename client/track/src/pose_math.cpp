#include "arlight/track/pose_math.hpp"

#include <cmath>

namespace arlight::track {

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
  // Rodrigues: rvec is the rotation's axis times its angle (cv::Rodrigues).
  const double angle = glm::length(rvec);
  const glm::dquat q = angle > 0 ? glm::angleAxis(angle, rvec / angle) : glm::dquat(1, 0, 0, 0);
  const glm::dmat3 rt = glm::transpose(glm::mat3_cast(q));  // R^T
  // x_marker = R^T (x_cv - t) and x_cv = F x_ours: orientation R^T F (columns 1, 2 negated).
  glm::dmat3 o = rt;
  o[1] = -o[1];
  o[2] = -o[2];
  return {glm::normalize(glm::quat_cast(o)), -(rt * tvec)};
}

}  // namespace arlight::track
