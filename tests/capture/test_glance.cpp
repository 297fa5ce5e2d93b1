// The glance (issue 37 §1, CaptureOptions::glance): a settled session's frame that agrees with
// the map is found unchanged from its 1/8-size decode alone and changes nothing; a light
// switched on, a view of what was never seen, and a lamp clipped where the map does not hold
// its floor yet are never glanced away.
#include <gtest/gtest.h>

#include <cmath>
#include <glm/gtc/quaternion.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <vector>

#include "arlight/capture/capture.hpp"
#include "arlight/common/resample.hpp"
#include "arlight/sim/view.hpp"
#include "glance.hpp"

using namespace arlight;
using namespace arlight::capture;

namespace {

const glm::dvec3 kLampDir = glm::normalize(glm::dvec3(0.0, 0.15, -1.0));

// A grey room brighter towards the ceiling, with texture; with the lamp, a 12-degree panel of
// radiance `lamp` straight ahead.
EnvMap room(double lamp = 0.0) {
  EnvMap env(EnvLayout::for_size(Projection::LatLong, 256));
  for (int y = 0; y < env.layout.height(); ++y)
    for (int x = 0; x < env.layout.width(); ++x) {
      const glm::dvec3 d = env.layout.texel_dir(x, y);
      double l = 0.15 + 0.05 * d.y + 0.03 * std::sin(9.0 * std::atan2(d.x, d.z));
      if (lamp > 0.0 && glm::dot(d, kLampDir) > std::cos(glm::radians(12.0))) l = lamp;
      env.image.set(x, y, glm::vec3(float(l)));
    }
  return env;
}

// arlightd's case: a 640x480 camera whose frames come at the advised 320x240 (q90 JPEG), into
// the capture map of --map-size 512.
const CameraIntrinsics kCamera = CameraIntrinsics::from_fov(640, 480, 60);
const CameraIntrinsics kSent = CameraIntrinsics::from_fov(320, 240, 60);

CaptureOptions options(bool glance = true) {
  CaptureOptions o;
  o.layout = capture_layout_for(512);
  o.align = false;
  o.fill = Fill::None;
  o.glance = glance;
  return o;
}

std::vector<std::uint8_t> jpeg_of(const EnvSampler& sampler, const glm::dquat& q,
                                  double exposure = 1.0) {
  std::vector<std::uint8_t> out;
  cv::imencode(".jpg", sim::ideal_view(sampler, kSent, q, exposure), out,
               {cv::IMWRITE_JPEG_QUALITY, 90});
  return out;
}

glm::dquat yaw_pitch(double yaw, double pitch) {
  return glm::angleAxis(glm::radians(yaw), glm::dvec3(0, 1, 0)) *
         glm::angleAxis(glm::radians(pitch), glm::dvec3(1, 0, 0));
}

// Two turns of views 30 degrees apart at pitch 0 (and +-40 unless `band_only`): the second
// agrees with the first.
void settle(CaptureSession& s, const EnvSampler& sampler, bool band_only = false,
            double exposure = 1.0) {
  for (int turn = 0; turn < 2; ++turn)
    for (double pitch : band_only ? std::vector<double>{0.0} : std::vector<double>{-40, 0, 40})
      for (int k = 0; k < 12; ++k)
        ASSERT_TRUE(s.add_encoded(jpeg_of(sampler, yaw_pitch(30.0 * k, pitch), exposure),
                                  {0.0, exposure, 1.0, yaw_pitch(30.0 * k, pitch)})
                        .used);
}

TEST(Glance, AFrameThatAgreesIsGlancedAndChangesNothing) {
  const EnvSampler sampler(room());
  CaptureSession s(kCamera, CameraResponse::srgb(), options());
  settle(s, sampler);
  const Accumulators before = s.accumulators();
  const ShCoeffs sh = s.sh();
  int glanced = 0;
  for (int k = 0; k < 12; ++k) {
    const FrameResult r = s.add_encoded(jpeg_of(sampler, yaw_pitch(30.0 * k + 15.0, 0)),
                                        {0.0, 1.0, 1.0, yaw_pitch(30.0 * k + 15.0, 0)});
    ASSERT_TRUE(r.used) << r.skipped_reason;
    EXPECT_TRUE(r.unchanged) << k << ": change " << r.change << ", bias " << r.bias;
    glanced += r.glanced;
  }
  EXPECT_GE(glanced, 10);  // views between the captured ones, so not the same pictures
  EXPECT_EQ(s.accumulators().weight, before.weight);
  EXPECT_EQ(s.accumulators().weighted_radiance, before.weighted_radiance);
  for (std::size_t i = 0; i < sh.c.size(); ++i) EXPECT_EQ(s.sh().c[i], sh.c[i]) << i;
}

TEST(Glance, ALightSwitchedOnIsNotGlancedAway) {
  CaptureSession s(kCamera, CameraResponse::srgb(), options());
  settle(s, EnvSampler(room()));
  const double l00 = s.sh().c[0].x;
  const EnvSampler lit(room(0.6));  // 3-4x the wall: not clipped at exposure 1
  const FrameResult r =
      s.add_encoded(jpeg_of(lit, yaw_pitch(0, 0)), {0.0, 1.0, 1.0, yaw_pitch(0, 0)});
  ASSERT_TRUE(r.used) << r.skipped_reason;
  EXPECT_FALSE(r.glanced);
  EXPECT_FALSE(r.unchanged);
  EXPECT_GT(s.sh().c[0].x, l00 * 1.02);
}

TEST(Glance, AViewOfWhatWasNeverSeenIsNotGlanced) {
  const EnvSampler sampler(room());
  CaptureSession s(kCamera, CameraResponse::srgb(), options());
  settle(s, sampler, /*band_only=*/true);
  const double coverage = s.coverage();
  const FrameResult r =
      s.add_encoded(jpeg_of(sampler, yaw_pitch(0, 70)), {0.0, 1.0, 1.0, yaw_pitch(0, 70)});
  ASSERT_TRUE(r.used) << r.skipped_reason;
  EXPECT_FALSE(r.glanced);
  EXPECT_GT(s.coverage(), coverage + 0.02);
}

TEST(Glance, ALampClippedAboveWhatTheMapHoldsIsNotGlanced) {
  // The lamp clips at exposure 1, so the map holds it at about the clip level; at exposure 1/2
  // its clipped pixels prove twice that: the exposure advice must see the frame.
  const EnvSampler sampler(room(40.0));
  CaptureSession s(kCamera, CameraResponse::srgb(), options());
  settle(s, sampler);
  const FrameResult same =
      s.add_encoded(jpeg_of(sampler, yaw_pitch(0, 0)), {0.0, 1.0, 1.0, yaw_pitch(0, 0)});
  EXPECT_TRUE(same.glanced) << "change " << same.change << ", bias " << same.bias;
  const FrameResult shorter =
      s.add_encoded(jpeg_of(sampler, yaw_pitch(0, 0), 0.5), {0.0, 0.5, 1.0, yaw_pitch(0, 0)});
  ASSERT_TRUE(shorter.used) << shorter.skipped_reason;
  EXPECT_FALSE(shorter.glanced);
  EXPECT_GT(shorter.clipped_unmeasured, 0.0);
}

TEST(Glance, WithoutTheOptionNothingIsGlanced) {
  const EnvSampler sampler(room());
  CaptureSession s(kCamera, CameraResponse::srgb(), options(/*glance=*/false));
  settle(s, sampler);
  const FrameResult r =
      s.add_encoded(jpeg_of(sampler, yaw_pitch(15, 0)), {0.0, 1.0, 1.0, yaw_pitch(15, 0)});
  EXPECT_TRUE(r.unchanged);
  EXPECT_FALSE(r.glanced);
}

TEST(BlockMap, ABlockIsTheMeanOfItsMeasuredTexelsAndFollowsTheirChanges) {
  const EnvLayout layout = EnvLayout::for_size(Projection::Cube, 8);
  const auto table = texel_table(layout);
  std::vector<float> wl(3 * layout.texel_count(), 0.0f), w(layout.texel_count(), 0.0f);
  // Face 0's top-left 2x2 block: three texels measured at 1, 2, 3 (weight 2), one not.
  const std::size_t texels[3] = {0, 1, 8};
  for (std::size_t i = 0; i < 3; ++i) {
    w[texels[i]] = 2.0f;
    for (int c = 0; c < 3; ++c) wl[3 * texels[i] + std::size_t(c)] = 2.0f * float(i + 1);
  }
  BlockMap blocks(layout, 2, table->solid_angle);
  // The block's centre: texel (0, 0) of the cube with half the face.
  const glm::dvec3 centre = EnvLayout::for_size(Projection::Cube, 4).texel_dir(0, 0);
  const auto& omega = table->solid_angle;  // a cube's table is in texel order
  const double seen = omega[0] + omega[1] + omega[8], all = seen + omega[9];
  const BlockMap::Block b = blocks.at(centre, wl, w);
  EXPECT_NEAR(b.radiance.x, (omega[0] + 2 * omega[1] + 3 * omega[8]) / seen, 1e-5);
  EXPECT_NEAR(b.measured, seen / all, 1e-6);  // the corner texel is the smallest
  EXPECT_FLOAT_EQ(b.peak, 3.0f);
  for (int c = 0; c < 3; ++c) wl[3 * 9 + std::size_t(c)] = 8.0f;
  w[9] = 2.0f;
  EXPECT_NEAR(blocks.at(centre, wl, w).measured, seen / all, 1e-6);  // not told: as it was
  blocks.touch(9);
  const BlockMap::Block after = blocks.at(centre, wl, w);
  EXPECT_NEAR(after.measured, 1.0f, 1e-6f);
  EXPECT_FLOAT_EQ(after.peak, 4.0f);
}

}  // namespace
