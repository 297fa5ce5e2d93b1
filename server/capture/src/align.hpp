// Drift correction by feature alignment (thesis ch. 3, after Kán [Kán15]): the environment map
// captured so far is rendered into the camera at the predicted orientation, its corners are
// followed into the frame by optical flow, and the rotation that carries the frame's rays onto
// the rendered ones is fitted robustly.
#pragma once

#include <glm/mat3x3.hpp>
#include <glm/vec3.hpp>
#include <span>
#include <string>

#include "arlight/common/camera.hpp"

namespace cv {
class Mat;
}

namespace arlight::capture {

// The rotation C minimising sum |C a_i - b_i|^2 (Kabsch / Horn, by SVD); needs >= 2 pairs.
glm::dmat3 fit_rotation(std::span<const glm::dvec3> a, std::span<const glm::dvec3> b);

struct RotationFit {
  bool ok = false;
  glm::dmat3 rotation{1.0};  // C with C * a_i ~ b_i for the inliers
  int matches = 0;           // candidate pairs
  int inliers = 0;
  std::string why;  // when !ok
};

// RANSAC over two-pair samples, then a least-squares refit on the inliers. A pair is an inlier
// when C a and b are within `threshold_rad`. Deterministic (fixed sample sequence).
RotationFit robust_rotation(std::span<const glm::dvec3> a, std::span<const glm::dvec3> b,
                            double threshold_rad, int min_inliers);

// Follows corners of `rendered` (8-bit gray of the map seen through the same camera as `frame`;
// `rendered_mask` non-zero where the map has data) into `frame` (8-bit gray) by pyramidal
// Lucas-Kanade flow, and fits the rotation that carries frame rays onto rendered rays, both in
// camera coordinates of `camera`. Only displacements up to `search_radius_px` count.
RotationFit align_to_rendered(const cv::Mat& frame, const cv::Mat& rendered,
                              const cv::Mat& rendered_mask, const PinholeCamera& camera,
                              int min_inliers, double search_radius_px);

}  // namespace arlight::capture
