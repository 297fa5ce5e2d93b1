// What a client sends arlightd and how often, as its LightingUpdates advise (PROTOCOL.md, frame
// advice; issue 37 §1): frames reduced to the size the server's map needs, at most the rate it
// needs now; and, when limit_in_flight() says so (issue 36 §1), at most a few frames in flight,
// so that a slow link or a busy daemon holds the newest frame back at the client instead of
// queueing seconds of frames between them. Part of the client core both clients share (the
// native pipeline, arlight-load and the page's WebAssembly); no clock or threads of its own: the
// caller says when a frame is due.
#pragma once

#include <cstdint>
#include <deque>
#include <utility>

#include "arlight/protocol/wire.hpp"

namespace arlight::client {

class FramePacer {
 public:
  struct Decision {
    bool send = true;
    int reduction = 1;  // send the frame this many times smaller each side (1, 2, 4 or 8)
  };

  // The advice of a LightingUpdate replaces the last (0 x 0 and 0: none, so every frame goes
  // at the camera's size). The update also answers every frame sent up to its frame_sequence
  // (it reflects the newest frame processed; the older ones were processed or dropped).
  void advise(const wire::LightingUpdate& update);

  // At most `frames` sent and not yet answered (0: no limit, the default). A frame unanswered
  // for kInFlightTimeout seconds counts as lost, so an update that never comes cannot stop the
  // frames for good. Frames held back for it count in held_back() and held_in_flight().
  void limit_in_flight(int frames) { max_in_flight_ = frames < 0 ? 0 : frames; }
  static constexpr double kInFlightTimeout = 2.0;
  // A new connection: nothing sent before is in flight on it.
  void forget_in_flight() { in_flight_.clear(); }
  int in_flight() const { return int(in_flight_.size()); }

  // A camera frame of width x height is due at `now_s` (seconds, any steady origin) from a
  // camera delivering `camera_fps`: whether to send it (not while the advised rate says the last
  // one went too recently, less half a camera frame of jitter) and reduced by how much (the
  // advised size when it is the camera's divided by 2, 4 or 8). Call sent() when it went.
  Decision frame_due(double now_s, int width, int height, double camera_fps);
  // The frame went, as `sequence` (0: not tracked for the in-flight limit).
  void sent(double now_s, std::uint64_t sequence = 0);
  // Whether a frame kept for a fail-over (unsaved_frames.hpp) may go again now: fewer than the
  // in-flight limit (at least kResendInFlight, even with none) are unanswered, so that frames
  // sent again arrive at the daemon's pace instead of overflowing its queue.
  bool may_resend(double now_s);
  static constexpr int kResendInFlight = 2;

  // Frames frame_due() held back, and the advice now.
  std::uint64_t held_back() const { return held_back_; }
  std::uint64_t held_in_flight() const { return held_in_flight_; }
  int advised_width() const { return width_; }
  int advised_height() const { return height_; }
  float advised_fps() const { return fps_; }

 private:
  int width_ = 0, height_ = 0;
  float fps_ = 0.0f;
  double last_sent_s_ = 0.0;
  bool any_sent_ = false;
  std::uint64_t held_back_ = 0, held_in_flight_ = 0;
  int max_in_flight_ = 0;
  void forget_lost(double now_s);  // frames unanswered for kInFlightTimeout
  std::deque<std::pair<std::uint64_t, double>> in_flight_;  // (sequence, sent at), oldest first
};

}  // namespace arlight::client
