// Unit tests of the simulated user who follows the daemon's proposed views
// (arlight/sim/guided_motion.hpp).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <glm/geometric.hpp>
#include <numbers>

#include "arlight/common/error.hpp"
#include "arlight/sim/guided_motion.hpp"

using namespace arlight;
using namespace arlight::sim;

namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

double angle_deg(const glm::dvec3& a, const glm::dvec3& b) {
  return std::acos(std::clamp(glm::dot(a, b), -1.0, 1.0)) / kDeg;
}

glm::dvec3 looking(const glm::dquat& q) { return q * glm::dvec3(0, 0, -1); }

}  // namespace

// A 120-degree turn at 90 deg/s and 360 deg/s^2: still for the reaction time, then a turn
// that never exceeds the rate, arriving after reaction + 120/90 + 90/360 s (the ramps) and
// holding there.
TEST(GuidedMotion, TurnsToTheProposalAtABoundedRateAfterTheReaction) {
  GuidedMotion user({.max_rate_deg_s = 90, .accel_deg_s2 = 360, .reaction_s = 0.3, .tremor = 0});
  const glm::dvec3 start(0, 0, -1);
  const glm::dvec3 target(std::sin(120 * kDeg), 0.0, -std::cos(120 * kDeg));
  user.propose(target, 0.0);
  EXPECT_LT(angle_deg(looking(user.at(0.29)), start), 1e-6);
  double prev_angle = 0.0, fastest = 0.0;
  double arrived = -1.0;
  for (int i = 1; i <= 300; ++i) {
    const double t = 0.3 + i / 100.0;
    const glm::dvec3 v = looking(user.at(t));
    const double a = angle_deg(v, start);
    fastest = std::max(fastest, (a - prev_angle) * 100.0);
    prev_angle = a;
    if (arrived < 0 && angle_deg(v, target) < 3.0) arrived = t;
    EXPECT_NEAR(v.y, 0.0, 1e-9);  // along the great circle (the horizon)
  }
  EXPECT_LE(fastest, 90.0 + 1e-6);
  EXPECT_GT(fastest, 85.0);
  const double expected = 0.3 + 120.0 / 90.0 + 90.0 / 360.0;
  EXPECT_NEAR(arrived, expected, 0.15);
  EXPECT_LT(angle_deg(user.view(), target), 3.0);
  EXPECT_NEAR(user.rate_deg_s(), 0.0, 1e-9);
}

// The same proposal repeated with every update changes nothing; a new one restarts the
// reaction; the tremor shakes the view by about the handheld path's 1.5 degrees, never more
// than a few.
TEST(GuidedMotion, RepeatsAreIgnoredAndTheTremorIsAHandsWorth) {
  GuidedMotion steady({.tremor = 0}), shaky({.tremor = 1, .seed = 7});
  const glm::dvec3 up(0, 1, 0);
  for (int i = 0; i < 400; ++i) {
    const double t = i / 100.0;
    steady.propose(up, t);  // the daemon says it again every frame
    shaky.propose(up, t);
    const double off = angle_deg(looking(shaky.at(t)), looking(steady.at(t)));
    EXPECT_LT(off, 6.0) << t;
  }
  EXPECT_LT(angle_deg(steady.view(), up), 3.0);  // arrived despite the repeats
  EXPECT_THROW(steady.propose(glm::dvec3(0.0), 4.0), InputError);
  EXPECT_THROW(GuidedMotion({.max_rate_deg_s = 0}), InputError);
}
