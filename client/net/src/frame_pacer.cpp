#include "arlight/net/frame_pacer.hpp"

#include <algorithm>

namespace arlight::client {

void FramePacer::advise(const wire::LightingUpdate& update) {
  width_ = update.advised_width, height_ = update.advised_height, fps_ = update.advised_fps;
  while (!in_flight_.empty() && in_flight_.front().first <= update.frame_sequence)
    in_flight_.pop_front();
}

void FramePacer::sent(double now_s, std::uint64_t sequence) {
  last_sent_s_ = now_s, any_sent_ = true;
  forget_lost(now_s);
  if (sequence > 0) in_flight_.emplace_back(sequence, now_s);
}

void FramePacer::forget_lost(double now_s) {
  while (!in_flight_.empty() && now_s - in_flight_.front().second > kInFlightTimeout)
    in_flight_.pop_front();
}

bool FramePacer::may_resend(double now_s) {
  forget_lost(now_s);
  return int(in_flight_.size()) < std::max(max_in_flight_, kResendInFlight);
}

FramePacer::Decision FramePacer::frame_due(double now_s, int width, int height,
                                           double camera_fps) {
  Decision d;
  forget_lost(now_s);
  if (max_in_flight_ > 0 && int(in_flight_.size()) >= max_in_flight_) {
    ++held_back_, ++held_in_flight_;
    d.send = false;
    return d;
  }
  if (fps_ > 0.0f && any_sent_) {
    const double jitter = camera_fps > 0.0 ? 0.5 / camera_fps : 0.0;
    if (now_s - last_sent_s_ < 1.0 / double(fps_) - jitter) {
      ++held_back_;
      d.send = false;
      return d;
    }
  }
  for (int k = 2; k <= 8; k *= 2)
    if (width_ > 0 && width % k == 0 && height % k == 0 && width / k == width_ &&
        height / k == height_)
      d.reduction = k;
  return d;
}

}  // namespace arlight::client
