// A simulated user who turns the phone towards the view the daemon asks for (issue 48 §2): the
// guided capture's counterpart of the fixed sweeps in trajectory.hpp. After a reaction time the
// camera's view direction turns along the great circle to the proposed one, speeding up and
// slowing down at a human rate (bounded acceleration and turning rate), holds there until a
// new proposal comes, and shakes with the handheld path's hand tremor (1.5 deg of yaw and pitch,
// 0.7 of roll, knots every 0.2 s). The camera is kept upright (no roll beyond the tremor).
#pragma once

#include <cstdint>
#include <glm/gtc/quaternion.hpp>
#include <glm/vec3.hpp>
#include <optional>
#include <vector>

namespace arlight::sim {

struct GuidedMotionParams {
  double max_rate_deg_s = 90.0;    // the fastest turn
  double accel_deg_s2 = 360.0;     // how fast a turn speeds up and slows down
  double reaction_s = 0.3;         // from a new proposal to the start of the turn
  double arrived_deg = 3.0;        // closer than this, the user holds the view
  double tremor = 1.0;             // the hand tremor's scale (0: a steady hand)
  glm::dvec3 start{0.0, 0.0, -1.0};  // the first view direction (unit)
  std::uint64_t seed = 0;
};

class GuidedMotion {
 public:
  explicit GuidedMotion(const GuidedMotionParams& params = {});

  // The newest proposal, made known at `time` (seconds); a direction within arrived_deg of the
  // one being followed changes nothing (the daemon repeats its proposal with every update).
  void propose(const glm::dvec3& direction, double time);
  // Camera -> world at `time` (seconds, not before the last call's): the motion is integrated
  // up to it in steps of at most 1/240 s.
  glm::dquat at(double time);
  // The view direction without the tremor, and the rate it is turning at (deg/s).
  const glm::dvec3& view() const { return view_; }
  double rate_deg_s() const { return rate_; }

 private:
  void advance(double dt);

  GuidedMotionParams p_;
  glm::dvec3 view_;
  double rate_ = 0.0, time_ = 0.0;
  std::optional<glm::dvec3> target_, pending_;
  double pending_at_ = 0.0;
  std::vector<double> jitter_[3];  // tremor knots (yaw, pitch, roll; degrees), grown as needed
};

}  // namespace arlight::sim
