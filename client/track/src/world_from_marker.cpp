// WorldFromMarker: a robust running average of R_world_cam * R_cam_marker.
#include <algorithm>
#include <cmath>
#include <vector>

#include "arlight/common/pose.hpp"
#include "arlight/track/world_from_marker.hpp"

namespace arlight::track {

namespace {

// The normalised sum of quaternions sign-aligned to `ref`: the chordal L2 mean of rotations,
// accurate for samples within a few degrees of each other.
glm::dquat mean_near(const std::vector<glm::dquat>& qs, const std::vector<bool>& use,
                     const glm::dquat& ref) {
  glm::dquat sum(0, 0, 0, 0);
  for (std::size_t i = 0; i < qs.size(); ++i)
    if (use[i]) sum += glm::dot(qs[i], ref) < 0 ? -qs[i] : qs[i];
  return glm::length(sum) > 0 ? glm::normalize(sum) : ref;
}

double median(std::vector<double> v) {
  if (v.empty()) return 0;
  const auto mid = v.begin() + std::ptrdiff_t(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

}  // namespace

void WorldFromMarker::reset() {
  samples_.clear();
  estimate_.reset();
  inliers_ = 0;
  spread_deg_ = 0;
}

void WorldFromMarker::add(double timestamp, const glm::dquat& world_from_camera,
                          const glm::dquat& marker_from_camera) {
  samples_.push_back({timestamp, glm::normalize(world_from_camera *
                                                glm::conjugate(marker_from_camera))});
  while (!samples_.empty() &&
         (samples_.size() > o_.max_samples || samples_.front().t < timestamp - o_.window_s))
    samples_.pop_front();
  estimate();
}

void WorldFromMarker::estimate() {
  if (samples_.size() < std::max<std::size_t>(1, o_.min_samples)) {
    estimate_.reset();
    return;
  }
  std::vector<glm::dquat> qs;
  for (const Sample& s : samples_) qs.push_back(s.q);
  const std::size_t n = qs.size();

  // Seed: the medoid (the sample with the smallest median angle to the others), robust to
  // up to half the samples being wrong (a mistracked frame, a bad IMU reading).
  std::size_t medoid = 0;
  double best = INFINITY;
  std::vector<double> angles(n);
  for (std::size_t i = 0; i < n; ++i) {
    for (std::size_t j = 0; j < n; ++j) angles[j] = angle_deg(qs[i], qs[j]);
    const double med = median(angles);
    if (med < best) best = med, medoid = i;
  }
  glm::dquat centre = qs[medoid];
  std::vector<bool> use(n, true);
  // Reject samples far from the centre (a multiple of the median absolute deviation, at least
  // outlier_min_deg), average the rest; twice, as the centre moves.
  for (int pass = 0; pass < 3; ++pass) {
    for (std::size_t j = 0; j < n; ++j) angles[j] = angle_deg(centre, qs[j]);
    const double limit = std::max(o_.outlier_min_deg, o_.outlier_mads * 1.4826 * median(angles));
    for (std::size_t j = 0; j < n; ++j) use[j] = angles[j] <= limit;
    centre = mean_near(qs, use, centre);
  }
  inliers_ = std::size_t(std::count(use.begin(), use.end(), true));
  for (std::size_t j = 0; j < n; ++j) angles[j] = angle_deg(centre, qs[j]);
  spread_deg_ = median(angles);
  estimate_ = centre;
}

}  // namespace arlight::track
