// The orientation sensor's heading drift as capture corrects it (thesis ch. 3, after Kán): a
// world-frame offset, used orientation = offset * sensor, that turns at a constant rate (a gyro
// bias). Each alignment measures the offset; the model moves part of the way towards it
// (smoothing) and fits the rate as the least-squares slope of the measured offsets (rotation
// vectors) over the last few seconds, once they span long enough to tell drift from noise.
// Frames between alignments, and stretches without features, are corrected by extrapolating.
#pragma once

#include <deque>
#include <glm/gtc/quaternion.hpp>
#include <utility>

namespace arlight::capture {

class DriftModel {
 public:
  // `smoothing`: the share of a measured correction applied at once (0, 1]; the fitted rate is
  // capped at `max_rate_deg_per_s`.
  DriftModel(double smoothing, double max_rate_deg_per_s)
      : smoothing_(smoothing), max_rate_deg_per_s_(max_rate_deg_per_s) {}

  // The offset at `timestamp` (seconds; non-finite: no time step): the last one turned on at the
  // fitted rate for the time since the previous call (steps over 5 s are not extrapolated).
  glm::dquat predict(double timestamp);
  // An alignment's measured offset at `timestamp`.
  void update(const glm::dquat& measured_offset, double timestamp);

  const glm::dquat& offset() const { return offset_; }
  const glm::dvec3& rate() const { return rate_; }  // world-frame rotation vector per second

  static constexpr double kRateWindow = 4.0;  // seconds of alignments the rate is fitted to

 private:
  double smoothing_, max_rate_deg_per_s_;
  glm::dquat offset_{1, 0, 0, 0};
  glm::dvec3 rate_{0.0};
  double last_time_ = 0;
  bool has_time_ = false;
  std::deque<std::pair<double, glm::dvec3>> history_;  // (time, measured offset rotation vector)
};

}  // namespace arlight::capture
