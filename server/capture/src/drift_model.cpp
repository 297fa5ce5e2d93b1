#include "drift_model.hpp"

#include <cmath>

#include "arlight/common/pose.hpp"

namespace arlight::capture {

glm::dquat DriftModel::predict(double timestamp) {
  const double dt = std::isfinite(timestamp) && has_time_ ? timestamp - last_time_ : 0.0;
  if (std::isfinite(timestamp)) last_time_ = timestamp, has_time_ = true;
  if (dt > 0.0 && dt < 5.0 && glm::length(rate_) > 0.0)
    offset_ =
        glm::normalize(glm::angleAxis(glm::length(rate_) * dt, glm::normalize(rate_)) * offset_);
  return offset_;
}

void DriftModel::update(const glm::dquat& measured_offset, double timestamp) {
  const glm::dvec3 r = log_map(measured_offset * glm::conjugate(offset_));
  if (glm::length(r) > 0.0)
    offset_ =
        glm::normalize(glm::angleAxis(smoothing_ * glm::length(r), glm::normalize(r)) * offset_);
  if (!std::isfinite(timestamp)) return;
  history_.push_back({timestamp, log_map(measured_offset)});
  while (!history_.empty() && history_.front().first < timestamp - kRateWindow)
    history_.pop_front();
  if (history_.size() < 8 || timestamp - history_.front().first < 0.5 * kRateWindow) return;
  double st = 0, stt = 0;
  glm::dvec3 sv(0.0), stv(0.0);
  for (const auto& [t, v] : history_) st += t, stt += t * t, sv += v, stv += t * v;
  const double n = double(history_.size()), den = n * stt - st * st;
  if (!(den > 0.0)) return;
  rate_ = (n * stv - st * sv) / den;
  const double max_rate = glm::radians(max_rate_deg_per_s_);
  if (glm::length(rate_) > max_rate) rate_ *= max_rate / glm::length(rate_);
}

}  // namespace arlight::capture
