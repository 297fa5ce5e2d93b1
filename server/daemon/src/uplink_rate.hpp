// The rate a client's uplink delivers its frames at, and the frame size that crosses it in a
// camera frame's time (issue 36 §1: JPEG size follows the link; PROTOCOL.md, frame advice).
// Measured from each frame message's arrival (MessageStream::Arrival): the bottleneck spaces the
// bytes of a frame written at once by bytes / rate, on any link and without the client's help (a
// page cannot read its socket's TCP_INFO). A sample is slower than the link when a loss made TCP
// retransmit (2 % of the packets lost: one frame in five) or the reader's thread was descheduled
// mid-message, and faster when segments came bunched, so the estimate is the median of the last
// kWindow samples. Frames too small to measure (they arrive whole) leave the samples to age out
// (kMaxAge): then the advice lapses, the client's frames grow back and are measured again, so a
// link that widened is found. No threads of its own.
#pragma once

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <utility>

#include "arlight/protocol/arrival.hpp"

namespace arlight::daemon {

class UplinkRate {
 public:
  using Clock = std::chrono::steady_clock;
  // Frames whose bytes after the first read are fewer than this tell too little: a few
  // segments may arrive together from any link's queue.
  static constexpr std::size_t kMinBytes = 3000;
  // A span shorter than this is measured as this: below a millisecond the scheduler, not the
  // link, sets it (and such a link is fast enough for any frame).
  static constexpr double kMinSeconds = 0.001;
  static constexpr std::size_t kWindow = 8;
  static constexpr Clock::duration kMaxAge = std::chrono::seconds(5);
  // A frame within this crosses the uplink: one camera frame at the 30 a second the advice asks
  // for while the map changes (Session::kChangingFps), so the link carries them all; two in
  // flight (FramePacer) wait at most two of it behind each other.
  static constexpr double kFrameSeconds = 1.0 / 30.0;
  // Advice over this limits no frame (a 1920x1080 JPEG at quality 90 is less; a link of more
  // than 240 Mbit/s): none is given.
  static constexpr double kNoLimitBytes = 1e6;

  // One frame message's arrival, at `now`.
  void arrived(const wire::Arrival& a, Clock::time_point now);
  // A new connection (the same client may come back on another link): nothing measured yet.
  void reset() { samples_.clear(); }

  // Bytes a second, the median of the window's samples younger than kMaxAge; 0: none.
  double bytes_per_second(Clock::time_point now);
  // The frame advice's advised_frame_bytes: what crosses in kFrameSeconds; 0 (no advice) without
  // a sample, and over kNoLimitBytes.
  std::uint32_t frame_bytes(Clock::time_point now);

 private:
  // (when, bytes a second), oldest first
  std::deque<std::pair<Clock::time_point, double>> samples_;
};

}  // namespace arlight::daemon
