#include "arlight/capture/exposure_advice.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace arlight::capture {

ExposureAdvisor::ExposureAdvisor(AdviceOptions options) : options_(options) {
  if (!(options_.stops_below > 0.0) || !(options_.min_clipped >= 0.0) ||
      options_.min_frames_between < 1 || options_.follow_frames < 1)
    throw std::invalid_argument("exposure advice: stops_below must be > 0, min_clipped >= 0, "
                                "min_frames_between and follow_frames >= 1");
}

std::optional<double> ExposureAdvisor::after_frame(const FrameResult& frame) {
  if (!frame.used || !(frame.exposure_gain > 0.0)) return std::nullopt;
  const double exposure = frame.exposure_gain;
  ++frames_since_;
  if (outstanding_ > 0.0) {
    darkest_since_ = darkest_since_ > 0.0 ? std::min(darkest_since_, exposure) : exposure;
    if (is_advised(exposure)) {
      ++followed_;
      outstanding_ = 0.0;
    } else if (frames_since_ > options_.follow_frames) {
      // Not followed: this is as dark as the client goes.
      limit_ = limit_ > 0.0 ? std::min(limit_, darkest_since_) : darkest_since_;
      outstanding_ = 0.0;
    } else {
      return std::nullopt;  // the advised frame may still be on its way
    }
  }
  double wanted = 0.0;
  if (frame.clipped_unmeasured >= options_.min_clipped && frame.clipped_floor > 0.0)
    wanted = std::exp2(-options_.stops_below) / frame.clipped_floor;
  // Never below what the client showed it can reach, and only when that is clearly darker
  // than this frame (else the advice cannot help).
  if (wanted > 0.0 && limit_ > 0.0) wanted = std::max(wanted, limit_);
  if (wanted > 0.0 && wanted > 0.7 * exposure) wanted = 0.0;
  if (wanted > 0.0) {
    if (frames_since_ < options_.min_frames_between) return std::nullopt;
    outstanding_ = wanted;
    darkest_since_ = 0.0;
    frames_since_ = 0;
    advising_ = true;
    ++advised_;
    return wanted;
  }
  if (advising_ && frame.clipped_unmeasured < options_.min_clipped) {
    advising_ = false;
    return 0.0;
  }
  return std::nullopt;
}

}  // namespace arlight::capture
