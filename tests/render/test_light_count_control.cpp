// Tutorial §6.4's frame-rate control (LightCountControl): the number of shadow lights that
// holds a target frame time, against a simulated renderer whose cost per light changes.
#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <stdexcept>
#include <vector>

#include "arlight/render/render.hpp"

namespace arlight::render {
namespace {

// A frame costs base + per_light x n milliseconds, with +-5 % noise and a late frame (x3) now and
// then (the machine, not the shadows).
struct SimulatedRenderer {
  double base = 10.0, per_light = 1.0;
  std::mt19937 rng{7};
  double frame(int n) {
    std::uniform_real_distribution<double> noise(0.95, 1.05);
    const double t = (base + per_light * n) * noise(rng);
    return std::uniform_int_distribution<int>(0, 49)(rng) == 0 ? 3.0 * t : t;
  }
};

struct ControlledRun {
  std::vector<int> lights;
  std::vector<double> frame_ms;
};
ControlledRun run(LightCountControl& control, SimulatedRenderer& renderer, int frames) {
  ControlledRun r;
  for (int i = 0; i < frames; ++i) {
    const int n = control.lights();
    const double ms = renderer.frame(n);
    r.lights.push_back(n), r.frame_ms.push_back(ms);
    control.update(ms);
  }
  return r;
}
double median(std::vector<double> v) {
  std::nth_element(v.begin(), v.begin() + std::ptrdiff_t(v.size() / 2), v.end());
  return v[v.size() / 2];
}

TEST(LightCountControl, HoldsTheTargetAsTheRendererSlowsDownAndRecovers) {
  constexpr double kTarget = 33.3;
  LightCountControl control(kTarget, 32, 1);
  SimulatedRenderer renderer;  // 10 ms + 1 ms a light: 23 lights fit
  const ControlledRun fast = run(control, renderer, 120);
  const std::vector<double> settled(fast.frame_ms.end() - 60, fast.frame_ms.end());
  EXPECT_LE(median(settled), kTarget);
  EXPECT_GE(fast.lights.back(), 17);  // uses the budget: within a few lights of 23
  EXPECT_LE(fast.lights.back(), 23);

  renderer.per_light = 4.0;  // slowed: 5 lights fit
  const ControlledRun slow = run(control, renderer, 60);
  // Back under the target within a fifth of a second at 30 fps, and stays there.
  const auto first_ok = std::find_if(slow.frame_ms.begin(), slow.frame_ms.end(),
                                     [&](double ms) { return ms <= kTarget; });
  EXPECT_LE(first_ok - slow.frame_ms.begin(), 6);
  const std::vector<double> slow_settled(slow.frame_ms.end() - 40, slow.frame_ms.end());
  EXPECT_LE(median(slow_settled), kTarget);
  EXPECT_GE(slow.lights.back(), 3);
  EXPECT_LE(slow.lights.back(), 5);

  renderer.per_light = 1.0;  // fast again: it climbs back
  const ControlledRun again = run(control, renderer, 150);
  EXPECT_GE(again.lights.back(), 17);
}

TEST(LightCountControl, OneLateFrameDoesNotCutTheLights) {
  LightCountControl control(30.0, 16, 8);
  EXPECT_EQ(control.update(20.0), 8);
  EXPECT_EQ(control.update(90.0), 8);  // one late frame
  EXPECT_EQ(control.update(20.0), 8);
  EXPECT_EQ(control.update(45.0), 8);
  EXPECT_LT(control.update(45.0), 8);  // two: cut in proportion to the excess (8 x 15 / 45)
  EXPECT_EQ(control.lights(), 5);
}

TEST(LightCountControl, NeverLeavesOneToMaxAndRefusesBadSettings) {
  LightCountControl control(10.0, 4, 2);
  for (int i = 0; i < 10; ++i) control.update(1000.0);
  EXPECT_EQ(control.lights(), 1);
  for (int i = 0; i < 100; ++i) control.update(0.1);
  EXPECT_EQ(control.lights(), 4);
  EXPECT_EQ(control.update(-1.0), 4);  // a broken clock changes nothing
  EXPECT_THROW(LightCountControl(0.0, 4), std::invalid_argument);
  EXPECT_THROW(LightCountControl(16.0, 0), std::invalid_argument);
  EXPECT_THROW(LightCountControl(16.0, kMaxShadowLights + 1), std::invalid_argument);
}

}  // namespace
}  // namespace arlight::render
