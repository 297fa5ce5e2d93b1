// Unit tests of the exposure estimate for frames whose exposure is unknown
// (CaptureOptions::estimate_exposure, issue 16 §4).
#include <gtest/gtest.h>

#include <cmath>
#include <glm/gtc/quaternion.hpp>
#include <opencv2/core.hpp>

#include "arlight/capture/capture.hpp"
#include "arlight/common/hdr_io.hpp"
#include "arlight/common/resample.hpp"
#include "arlight/sim/view.hpp"

using namespace arlight;
using namespace arlight::capture;

namespace {

constexpr int kViews = 24;

glm::dquat view(int k) {  // a turn at the horizon, 20 degrees a step (60-degree camera)
  return glm::angleAxis(glm::radians(20.0 * k), glm::dvec3(0, 1, 0));
}

// The auto-exposure of view k: rising over x8 along the turn, then falling back.
double exposure_of(int k) { return 0.05 * std::exp2(3.0 * std::sin(3.14159265 * k / kViews)); }

// What a 160x120 sRGB camera at exposure `exposure` sees of venice towards `q`.
cv::Mat render(const EnvSampler& sampler, const PinholeCamera& cam, glm::dquat q, double exposure) {
  return sim::ideal_view(sampler, cam.intrinsics(), q, exposure);
}

struct TurnCapture {
  EnvMap map;
  std::vector<FrameResult> results;
};

// The turn captured with the exposures known, or withheld (every frame said to be at the
// first's) with or without the estimate.
TurnCapture capture_turn(bool known, bool estimate) {
  static const EnvMap venice =
      resample(load_envmap(std::string(ARLIGHT_SOURCE_DIR) + "/data/probes/venice.exr").env,
               EnvLayout::for_size(Projection::LatLong, 128));
  static const EnvSampler sampler(venice);
  const CameraIntrinsics k = CameraIntrinsics::from_fov(160, 120, 60);
  CaptureOptions o;
  o.layout = EnvLayout::for_size(Projection::AngleMap, 128);
  o.align = false;
  o.fill = Fill::None;
  o.estimate_exposure = estimate;
  CaptureSession s(k, CameraResponse::srgb(), o);
  TurnCapture run{EnvMap(o.layout), {}};
  for (int v = 0; v < kViews; ++v) {
    const cv::Mat im = render(sampler, PinholeCamera(k), view(v), exposure_of(v));
    const double said = known ? exposure_of(v) : exposure_of(0);
    run.results.push_back(s.add_image(im, {0.0, said, 1.0, view(v)}));
  }
  run.map = s.measured_environment();
  return run;
}

// Mean relative difference of the luminance of texels both maps have.
double mean_difference(const EnvMap& a, const EnvMap& b) {
  double sum = 0.0;
  int n = 0;
  for (int y = 0; y < a.layout.height(); ++y)
    for (int x = 0; x < a.layout.width(); ++x) {
      const double la = luminance(glm::dvec3(a.image.at(x, y)));
      const double lb = luminance(glm::dvec3(b.image.at(x, y)));
      if (la > 1e-4 && lb > 1e-4) sum += std::abs(lb - la) / la, ++n;
    }
  EXPECT_GT(n, 1000);
  return sum / n;
}

}  // namespace

TEST(ExposureEstimate, FramesOfUnknownExposureBuildTheMapOfKnownOnes) {
  const TurnCapture known = capture_turn(true, false);
  const TurnCapture locked = capture_turn(false, false);
  const TurnCapture estimated = capture_turn(false, true);
  // Each frame's exposure x gain, measured from its overlap with the map, against the truth
  // (the first frame's is taken as said: it sets the scale).
  EXPECT_FALSE(estimated.results[0].exposure_estimated);
  EXPECT_DOUBLE_EQ(estimated.results[0].exposure_gain, exposure_of(0));
  double worst_stops = 0.0;
  for (int v = 1; v < kViews; ++v) {
    const FrameResult& r = estimated.results[std::size_t(v)];
    ASSERT_TRUE(r.used) << v;
    EXPECT_TRUE(r.exposure_estimated) << v;
    EXPECT_GT(r.exposure_samples, 100) << v;
    worst_stops = std::max(worst_stops, std::abs(std::log2(r.exposure_gain / exposure_of(v))));
  }
  EXPECT_LT(worst_stops, 0.1);
  const double e_estimated = mean_difference(known.map, estimated.map);
  const double e_locked = mean_difference(known.map, locked.map);
  std::printf(
      "worst exposure error %.3f stops; map vs known exposures: estimated %.2f %%, "
      "locked %.2f %%\n",
      worst_stops, 100 * e_estimated, 100 * e_locked);
  EXPECT_LT(e_estimated, 0.03);
  EXPECT_GT(e_locked, 0.5);
}

TEST(ExposureEstimate, AFrameThatOverlapsNothingKeepsTheLastEstimate) {
  const EnvMap grey(EnvLayout::for_size(Projection::LatLong, 64), Image(128, 64, glm::vec3(0.5f)));
  const EnvSampler sampler(grey);
  const CameraIntrinsics k = CameraIntrinsics::from_fov(160, 120, 60);
  CaptureOptions o;
  o.layout = EnvLayout::for_size(Projection::AngleMap, 128);
  o.align = false;
  o.estimate_exposure = true;
  CaptureSession s(k, CameraResponse::srgb(), o);
  const PinholeCamera cam(k);
  // Looking ahead at 0.1 s, then to the side at 0.2 s (overlapping: measured), then behind at
  // 0.4 s (nothing there yet: the last estimate, 0.2 s, stays).
  const auto add = [&](double yaw, double exposure) {
    const glm::dquat q = glm::angleAxis(glm::radians(yaw), glm::dvec3(0, 1, 0));
    return s.add_image(render(sampler, cam, q, exposure), {0.0, 0.1, 1.0, q});
  };
  EXPECT_NEAR(add(0, 0.1).exposure_gain, 0.1, 1e-12);
  const FrameResult side = add(30, 0.2);
  EXPECT_TRUE(side.exposure_estimated);
  EXPECT_NEAR(std::log2(side.exposure_gain / 0.2), 0.0, 0.05);
  const FrameResult behind = add(180, 0.4);
  EXPECT_FALSE(behind.exposure_estimated);
  EXPECT_LT(behind.exposure_samples, 64);
  EXPECT_DOUBLE_EQ(behind.exposure_gain, side.exposure_gain);
}
