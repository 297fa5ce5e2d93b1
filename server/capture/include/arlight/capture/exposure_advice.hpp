// Exposure advice (issue 16 §4): HDR without clipped lights. A phone's auto-exposure meters the
// room, so a lamp or the sun clips in every frame and the captured map only holds a lower bound
// for it (lab.exr's lamps, ~90x the room's mean, leave its irradiance ~30 % too dark). Instead
// of a fixed bracket (every second frame some stops darker: arlight-sim --hdr-stops), the
// capture says when a frame shows a light no frame has measured unclipped yet, and how dark the
// next frame must be to see it: like the exposure bracketing of an HDR capture app, but only
// while and where it is needed.
//
// The advised exposure x gain puts the brightest proved radiance among those texels (their clip
// floor, FrameResult::clipped_floor) `stops_below` stops under clipping. A frame taken at it
// either measures the light (its texels then hold more than their floor and the advice stops)
// or clips again, which raises the floor to what that darker frame proves, so the next advice
// is `stops_below` stops darker again: a light R times the floor takes about
// log2(R)/stops_below advised frames.
#pragma once

#include <cstddef>
#include <optional>

#include "arlight/capture/capture.hpp"

namespace arlight::capture {

struct AdviceOptions {
  double min_clipped = 0.001;  // advise when at least this fraction of a frame is unmeasured
  // The brightest clip floor goes this far below clipping: lab's lamps within 2.6 % with 48
  // advised frames of 240 at 5 stops, 6.4 % with 46 at 3 (a floor is a lower bound; the
  // light's core is brighter still).
  double stops_below = 5.0;
  int min_frames_between = 3;  // at most one advised frame in this many: the rest meter the room
  // A client that has not sent a frame at (or below 1.25x) the advised exposure this many
  // frames after the advice cannot go that dark (or cannot set its exposure): the darkest frame
  // it sent meanwhile is its limit, and no advice asks for less than that again.
  int follow_frames = 15;
};

// One per capturing session; feed it every frame's result, in order.
class ExposureAdvisor {
 public:
  explicit ExposureAdvisor(AdviceOptions options = {});

  // After a frame: the exposure x gain to ask for next; 0 when advice was given before and
  // this frame shows nothing left to measure (the client may drop an advice it has not used);
  // nothing when there is nothing new to say.
  std::optional<double> after_frame(const FrameResult& frame);

  // Whether a frame at this exposure x gain is the one the outstanding advice asked for.
  bool is_advised(double exposure_gain) const {
    return outstanding_ > 0.0 && exposure_gain <= 1.25 * outstanding_;
  }
  std::size_t advised() const { return advised_; }    // advices given (not counting the 0s)
  std::size_t followed() const { return followed_; }  // frames taken at an advice
  double darkest_reachable() const { return limit_; }  // 0 until a client missed an advice

 private:
  AdviceOptions options_;
  double outstanding_ = 0.0;  // the advised exposure no frame has followed yet (0: none)
  double darkest_since_ = 0.0;  // the darkest frame since that advice
  int frames_since_ = 1 << 20;  // frames since the last advice
  double limit_ = 0.0;          // the darkest exposure the client reached when it could not follow
  bool advising_ = false;       // the last message was an advice, not a 0
  std::size_t advised_ = 0, followed_ = 0;
};

}  // namespace arlight::capture
