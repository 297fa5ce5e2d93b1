#include "align.hpp"

#include <algorithm>
#include <cmath>
#include <glm/geometric.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>
#include <random>
#include <vector>

namespace arlight::capture {

glm::dmat3 fit_rotation(std::span<const glm::dvec3> a, std::span<const glm::dvec3> b) {
  cv::Matx33d h = cv::Matx33d::zeros();
  for (std::size_t i = 0; i < a.size(); ++i)
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) h(r, c) += a[i][r] * b[i][c];
  cv::Matx33d u, vt;
  cv::Matx31d s;
  cv::SVD::compute(h, s, u, vt);
  // C = V diag(1, 1, det(V U^T)) U^T: the proper rotation closest to the correlation.
  const cv::Matx33d v = vt.t();
  const double d = cv::determinant(v * u.t()) < 0 ? -1.0 : 1.0;
  const cv::Matx33d c = v * cv::Matx33d(1, 0, 0, 0, 1, 0, 0, 0, d) * u.t();
  glm::dmat3 out;
  for (int r = 0; r < 3; ++r)
    for (int k = 0; k < 3; ++k) out[k][r] = c(r, k);  // glm is column-major
  return out;
}

RotationFit robust_rotation(std::span<const glm::dvec3> a, std::span<const glm::dvec3> b,
                            double threshold_rad, int min_inliers) {
  RotationFit fit;
  fit.matches = int(a.size());
  if (fit.matches < std::max(min_inliers, 2)) {
    fit.why = std::to_string(fit.matches) + " feature matches (need " +
              std::to_string(std::max(min_inliers, 2)) + ")";
    return fit;
  }
  const double cos_threshold = std::cos(threshold_rad);
  const auto inliers_of = [&](const glm::dmat3& c, std::vector<std::size_t>* which) {
    int n = 0;
    for (std::size_t i = 0; i < a.size(); ++i)
      if (glm::dot(c * a[i], b[i]) >= cos_threshold) {
        ++n;
        if (which) which->push_back(i);
      }
    return n;
  };
  std::mt19937 rng(12345);  // fixed: the same frames give the same correction
  std::uniform_int_distribution<std::size_t> pick(0, a.size() - 1);
  glm::dmat3 best(1.0);
  int best_count = -1;
  // Stops once a two-pair sample free of outliers has been drawn with 99.9 % probability at
  // the best inlier ratio so far (at least 20 samples, at most 200).
  int needed = 200;
  for (int iter = 0; iter < needed; ++iter) {
    const std::size_t i = pick(rng), j = pick(rng);
    if (i == j || std::abs(glm::dot(a[i], a[j])) > 0.99999) continue;
    const glm::dvec3 sa[2] = {a[i], a[j]}, sb[2] = {b[i], b[j]};
    const glm::dmat3 c = fit_rotation(sa, sb);
    const int count = inliers_of(c, nullptr);
    if (count > best_count) {
      best_count = count, best = c;
      const double clean = std::pow(double(count) / double(a.size()), 2.0);
      if (clean >= 1.0)
        needed = 20;
      else if (clean > 0.0)
        needed = std::clamp(int(std::ceil(std::log(1e-3) / std::log(1.0 - clean))), 20, 200);
    }
  }
  std::vector<std::size_t> idx;
  inliers_of(best, &idx);
  // Refit on the inliers, then once more with the inliers of the refit.
  for (int round = 0; round < 2 && idx.size() >= 2; ++round) {
    std::vector<glm::dvec3> ia, ib;
    for (std::size_t i : idx) ia.push_back(a[i]), ib.push_back(b[i]);
    best = fit_rotation(ia, ib);
    idx.clear();
    inliers_of(best, &idx);
  }
  fit.inliers = int(idx.size());
  fit.rotation = best;
  fit.ok = fit.inliers >= min_inliers && fit.inliers * 3 >= fit.matches;
  if (!fit.ok)
    fit.why = std::to_string(fit.inliers) + " of " + std::to_string(fit.matches) +
              " feature matches agree on a rotation (need " + std::to_string(min_inliers) + ")";
  return fit;
}

RotationFit align_to_rendered(const cv::Mat& frame, const cv::Mat& rendered,
                              const cv::Mat& rendered_mask, const PinholeCamera& camera,
                              int min_inliers, double search_radius_px) {
  // Local contrast equalisation (CLAHE) on both images, the same way, so that faint texture
  // (clouds, walls) gives corners too and the two look alike to the flow.
  static thread_local cv::Ptr<cv::CLAHE> clahe = cv::createCLAHE(4.0, cv::Size(4, 4));
  cv::Mat frame_eq, rendered_eq;
  clahe->apply(frame, frame_eq);
  clahe->apply(rendered, rendered_eq);
  // Corners only where the rendering has data, away from the edge of the captured region (a
  // strong artificial edge).
  cv::Mat mask;
  cv::erode(rendered_mask, mask, cv::getStructuringElement(cv::MORPH_RECT, {15, 15}));
  std::vector<cv::Point2f> corners;
  cv::goodFeaturesToTrack(rendered_eq, corners, 200, 0.005, 5.0, mask, 3);
  RotationFit none;
  if (corners.size() < std::size_t(min_inliers)) {
    none.why = std::to_string(corners.size()) + " corners in the captured part of the view";
    return none;
  }
  // The rendering is at the predicted orientation, so each corner lies within the largest
  // correction we accept of where it is in the frame: pyramidal Lucas-Kanade finds it there
  // to a fraction of a pixel (sharper than ORB keypoints, at a fraction of the cost). Wrong
  // tracks are left to the robust fit; tracking back as well cost twice and gained nothing.
  const cv::Size window(13, 13);
  const int levels = std::max(1, int(std::ceil(std::log2(std::max(1.0, search_radius_px / 4.0)))));
  const cv::TermCriteria stop(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 10, 0.03);
  std::vector<cv::Point2f> found;
  std::vector<std::uint8_t> tracked;
  std::vector<float> err;
  cv::calcOpticalFlowPyrLK(rendered_eq, frame_eq, corners, found, tracked, err, window, levels,
                           stop);
  std::vector<glm::dvec3> a, b;
  const float r2 = float(search_radius_px * search_radius_px);
  for (std::size_t i = 0; i < corners.size(); ++i) {
    if (!tracked[i]) continue;
    const cv::Point2f d = found[i] - corners[i];
    if (d.x * d.x + d.y * d.y > r2) continue;
    if (found[i].x < 0 || found[i].y < 0 || found[i].x > frame.cols - 1 ||
        found[i].y > frame.rows - 1)
      continue;
    a.push_back(camera.unproject({found[i].x, found[i].y}));
    b.push_back(camera.unproject({corners[i].x, corners[i].y}));
  }
  // One pixel of the alignment image: the flow localises to a fraction of one.
  return robust_rotation(a, b, 1.0 / camera.intrinsics().fx, min_inliers);
}

}  // namespace arlight::capture
