// nearest_rotation (orientation.hpp): the orthogonal Procrustes solution by OpenCV's SVD.
#include <opencv2/core.hpp>

#include "arlight/track/orientation.hpp"

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

}  // namespace arlight::track
