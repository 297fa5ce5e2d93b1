// What a client sends arlightd and how often, as its LightingUpdates advise (PROTOCOL.md, frame
// advice; issue 37 §1): frames reduced to the size the server's map needs, at most the rate it
// needs now, at a JPEG quality whose frames fit the bytes the server measured the uplink to
// carry in 1/30 s (issue 36 §1); and, when limit_in_flight() says so, at most a few frames in
// flight, so that a slow link or a busy daemon holds the newest frame back at the client instead
// of queueing seconds of frames between them. Part of the client core both clients share (the
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
  // The JPEG qualities a frame is encoded at, best first (kMaxQuality without byte advice), and
  // what a frame at each comes to against one at kMaxQuality (libjpeg-turbo's tables, 4:2:0; the
  // mean over rendered rooms and photographs at 320x240, which vary by +-0.08 about it).
  static constexpr int kQualities[] = {90, 80, 70, 60, 50};
  static constexpr double kRelativeBytes[] = {1.0, 0.61, 0.47, 0.39, 0.34};
  static constexpr int kMaxQuality = kQualities[0];
  // A higher quality is taken only when its frame is expected within this share of the advice
  // (the table is a mean: without the margin a frame could swing between two qualities).
  static constexpr double kQualityUpMargin = 0.85;

  struct Decision {
    bool send = true;
    int reduction = 1;  // send the frame this many times smaller each side (1, 2, 4 or 8)
    int quality = kMaxQuality;  // JPEG quality to encode it at (one of kQualities)
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
  // A frame of width x height encoded at `quality` came to `bytes`: what the next frames'
  // quality is chosen by (the newest frame's bytes a pixel, scaled by kRelativeBytes).
  void encoded(std::size_t bytes, int width, int height, int quality);
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
  std::uint32_t advised_frame_bytes() const { return frame_bytes_; }
  int quality() const { return quality_; }  // the newest decision's

 private:
  int width_ = 0, height_ = 0;
  float fps_ = 0.0f;
  std::uint32_t frame_bytes_ = 0;
  double max_quality_bytes_per_pixel_ = 0;  // the newest frame's, at kMaxQuality (0: none yet)
  int quality_ = kMaxQuality;
  int choose_quality(int pixels) const;
  double last_sent_s_ = 0.0;
  bool any_sent_ = false;
  std::uint64_t held_back_ = 0, held_in_flight_ = 0;
  int max_in_flight_ = 0;
  void forget_lost(double now_s);  // frames unanswered for kInFlightTimeout
  std::deque<std::pair<std::uint64_t, double>> in_flight_;  // (sequence, sent at), oldest first
};

}  // namespace arlight::client
