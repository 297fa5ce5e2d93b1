#include "align.hpp"

#include <algorithm>
#include <cmath>
#include <glm/geometric.hpp>
#include <opencv2/core.hpp>
#include <opencv2/core/hal/hal.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>
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
  for (int iter = 0; iter < 200; ++iter) {
    const std::size_t i = pick(rng), j = pick(rng);
    if (i == j || std::abs(glm::dot(a[i], a[j])) > 0.99999) continue;
    const glm::dvec3 sa[2] = {a[i], a[j]}, sb[2] = {b[i], b[j]};
    const glm::dmat3 c = fit_rotation(sa, sb);
    const int count = inliers_of(c, nullptr);
    if (count > best_count) best_count = count, best = c;
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
  // ORB with a patch that suits ~320x240 views; features are only taken from the part of the
  // rendering that has data, eroded so the edge of the captured region (a strong artificial
  // edge) yields no features.
  static thread_local cv::Ptr<cv::ORB> orb =
      cv::ORB::create(500, 1.2f, 4, 19, 0, 2, cv::ORB::HARRIS_SCORE, 19, 5);
  // Local contrast equalisation (CLAHE) on both images, the same way, so that faint texture
  // (clouds, walls) gives corners too.
  static thread_local cv::Ptr<cv::CLAHE> clahe = cv::createCLAHE(4.0, cv::Size(4, 4));
  cv::Mat frame_eq, rendered_eq;
  clahe->apply(frame, frame_eq);
  clahe->apply(rendered, rendered_eq);
  cv::Mat mask;
  cv::erode(rendered_mask, mask, cv::getStructuringElement(cv::MORPH_RECT, {15, 15}));
  std::vector<cv::KeyPoint> kf, kr;
  cv::Mat df, dr;
  orb->detectAndCompute(rendered_eq, mask, kr, dr);
  RotationFit none;
  if (kr.size() < std::size_t(min_inliers)) {
    none.why = std::to_string(kr.size()) + " features in the captured part of the view";
    return none;
  }
  orb->detectAndCompute(frame_eq, cv::noArray(), kf, df);
  if (kf.size() < std::size_t(min_inliers)) {
    none.why = std::to_string(kf.size()) + " features in the frame";
    return none;
  }
  // The rendering is at the predicted orientation, so a feature's match lies within the
  // largest correction we accept of where it is in the frame: matching only there (best
  // Hamming distance, Lowe's ratio test against the runner-up) keeps weak texture usable.
  std::vector<glm::dvec3> a, b;
  const float r2 = float(search_radius_px * search_radius_px);
  for (std::size_t i = 0; i < kf.size(); ++i) {
    int best = -1, best_d = 1 << 30, second_d = 1 << 30;
    for (std::size_t j = 0; j < kr.size(); ++j) {
      const cv::Point2f d = kf[i].pt - kr[j].pt;
      if (d.x * d.x + d.y * d.y > r2) continue;
      const int dist = cv::hal::normHamming(df.ptr<uchar>(int(i)), dr.ptr<uchar>(int(j)), df.cols);
      if (dist < best_d)
        second_d = best_d, best_d = dist, best = int(j);
      else if (dist < second_d)
        second_d = dist;
    }
    if (best < 0 || best_d > 64 || float(best_d) > 0.8f * float(second_d)) continue;
    const cv::Point2f pf = kf[i].pt, pr = kr[std::size_t(best)].pt;
    a.push_back(camera.unproject({pf.x, pf.y}));
    b.push_back(camera.unproject({pr.x, pr.y}));
  }
  // Two pixels of the alignment image: matches are localised to about a pixel.
  return robust_rotation(a, b, 2.0 / camera.intrinsics().fx, min_inliers);
}

}  // namespace arlight::capture
