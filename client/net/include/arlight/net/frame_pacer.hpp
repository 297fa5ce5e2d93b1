// What a client sends arlightd and how often, as its LightingUpdates advise (PROTOCOL.md, frame
// advice; issue 37 §1): frames reduced to the size the server's map needs, at most the rate it
// needs now. Part of the client core both clients share (the native pipeline, arlight-load and
// the page's WebAssembly); no clock or threads of its own: the caller says when a frame is due.
#pragma once

#include <cstdint>

#include "arlight/protocol/wire.hpp"

namespace arlight::client {

class FramePacer {
 public:
  struct Decision {
    bool send = true;
    int reduction = 1;  // send the frame this many times smaller each side (1, 2, 4 or 8)
  };

  // The advice of a LightingUpdate replaces the last (0 x 0 and 0: none, so every frame goes
  // at the camera's size).
  void advise(const wire::LightingUpdate& update);

  // A camera frame of width x height is due at `now_s` (seconds, any steady origin) from a
  // camera delivering `camera_fps`: whether to send it (not while the advised rate says the last
  // one went too recently, less half a camera frame of jitter) and reduced by how much (the
  // advised size when it is the camera's divided by 2, 4 or 8). Call sent() when it went.
  Decision frame_due(double now_s, int width, int height, double camera_fps);
  void sent(double now_s) { last_sent_s_ = now_s, any_sent_ = true; }

  // Frames frame_due() held back, and the advice now.
  std::uint64_t held_back() const { return held_back_; }
  int advised_width() const { return width_; }
  int advised_height() const { return height_; }
  float advised_fps() const { return fps_; }

 private:
  int width_ = 0, height_ = 0;
  float fps_ = 0.0f;
  double last_sent_s_ = 0.0;
  bool any_sent_ = false;
  std::uint64_t held_back_ = 0;
};

}  // namespace arlight::client
