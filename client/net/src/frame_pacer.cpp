#include "arlight/net/frame_pacer.hpp"

#include <algorithm>
#include <iterator>

namespace arlight::client {

void FramePacer::advise(const wire::LightingUpdate& update) {
  width_ = update.advised_width, height_ = update.advised_height, fps_ = update.advised_fps;
  frame_bytes_ = update.advised_frame_bytes;
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
  d.quality = quality_ = choose_quality((width / d.reduction) * (height / d.reduction));
  return d;
}

namespace {

// kRelativeBytes at `quality`, between the table's entries linearly (clamped to its ends).
double relative_bytes(int quality) {
  constexpr auto& q = FramePacer::kQualities;
  constexpr auto& r = FramePacer::kRelativeBytes;
  constexpr std::size_t n = std::size(q);
  if (quality >= q[0]) return r[0];
  for (std::size_t i = 1; i < n; ++i)
    if (quality >= q[i])
      return r[i] + (r[i - 1] - r[i]) * double(quality - q[i]) / (q[i - 1] - q[i]);
  return r[n - 1];
}

}  // namespace

void FramePacer::encoded(std::size_t bytes, int width, int height, int quality) {
  if (bytes == 0 || width <= 0 || height <= 0) return;
  max_quality_bytes_per_pixel_ = double(bytes) / (double(width) * height) / relative_bytes(quality);
}

int FramePacer::choose_quality(int pixels) const {
  if (frame_bytes_ == 0 || max_quality_bytes_per_pixel_ <= 0) return kMaxQuality;
  for (std::size_t i = 0; i < std::size(kQualities); ++i) {
    const double expected = max_quality_bytes_per_pixel_ * kRelativeBytes[i] * pixels;
    const double allowed = frame_bytes_ * (kQualities[i] > quality_ ? kQualityUpMargin : 1.0);
    if (expected <= allowed) return kQualities[i];
  }
  return kQualities[std::size(kQualities) - 1];
}

}  // namespace arlight::client
