// Tutorial §6.4's frame-rate control (LightCountControl, render.hpp).
#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "arlight/render/render.hpp"

namespace arlight::render {

LightCountControl::LightCountControl(double target_ms, int max_lights, int start)
    : target_ms_(target_ms),
      max_lights_(max_lights),
      lights_(std::clamp(start, 1, std::max(max_lights, 1))) {
  if (!(target_ms > 0) || !std::isfinite(target_ms))
    throw std::invalid_argument("LightCountControl: the target frame time must be positive");
  if (max_lights < 1 || max_lights > kMaxShadowLights)
    throw std::invalid_argument("LightCountControl: max_lights must be in [1, " +
                                std::to_string(kMaxShadowLights) + "]");
}

int LightCountControl::update(double frame_ms) {
  if (!(frame_ms >= 0) || !std::isfinite(frame_ms)) return lights_;  // no usable time: keep
  // Over the target for two frames in a row (one late frame is the machine, not the shadows):
  // cut in proportion to the excess, as if all of the frame were the lights' (it is not, so
  // the cut overshoots a little and the count climbs back).
  const double recent = std::min(frame_ms, last_ms_);
  last_ms_ = frame_ms;
  if (recent > target_ms_) {
    const int cut = std::max(1, int(std::ceil(lights_ * (recent - target_ms_) / recent)));
    lights_ = std::max(1, lights_ - cut);
    calm_frames_ = 0;
    last_ms_ = 0;  // the next frame is drawn with the new count: judge it afresh
  } else if (frame_ms < kHeadroom * target_ms_) {
    if (++calm_frames_ >= kPatience && lights_ < max_lights_) ++lights_, calm_frames_ = 0;
  } else {
    calm_frames_ = 0;
  }
  return lights_;
}

}  // namespace arlight::render
