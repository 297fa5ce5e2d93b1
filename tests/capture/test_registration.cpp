// Two phones, one room (issue 49 §1): a contributor's frames registered with the session's map.
// Its sensor shares gravity with the map but not heading, and its camera's sensitivity is its
// own: it registers at its heading whatever that is, its frames wait until then and are merged
// after, its sensitivity is matched, and a view of another room is never merged.
#include <gtest/gtest.h>

#include <cmath>
#include <glm/gtc/quaternion.hpp>
#include <numbers>
#include <opencv2/core.hpp>

#include "arlight/capture/capture.hpp"
#include "arlight/common/hdr_io.hpp"
#include "arlight/common/pose.hpp"
#include "arlight/common/resample.hpp"
#include "arlight/common/sh.hpp"
#include "arlight/sim/view.hpp"
#include "registration.hpp"

using namespace arlight;
using namespace arlight::capture;

namespace {

const CameraIntrinsics kCamera = CameraIntrinsics::from_fov(160, 120, 60);

const EnvSampler& probe(const std::string& name) {
  static std::map<std::string, std::unique_ptr<EnvSampler>> cache;
  auto& s = cache[name];
  if (!s) {
    static std::vector<std::unique_ptr<EnvMap>> maps;
    maps.push_back(std::make_unique<EnvMap>(resample(
        load_envmap(std::string(ARLIGHT_SOURCE_DIR) + "/data/probes/" + name + ".exr").env,
        EnvLayout::for_size(Projection::LatLong, 256))));
    s = std::make_unique<EnvSampler>(*maps.back());
  }
  return *s;
}

// The world view at yaw and pitch (degrees).
glm::dquat view(double yaw, double pitch) {
  return glm::normalize(glm::angleAxis(glm::radians(yaw), glm::dvec3(0, 1, 0)) *
                        glm::angleAxis(glm::radians(pitch), glm::dvec3(1, 0, 0)));
}

CaptureOptions options() {
  CaptureOptions o;
  o.layout = capture_layout_for(256);
  o.fill = Fill::None;
  o.align = false;  // the sensors here are exact: what is tested is the heading search
  o.glance = false;
  return o;
}

// Adds `device`'s view of `room` at world orientation `world`. The device's sensor heading
// origin is `heading` degrees off (it reads R_y(-heading) * world); it says `exposure` seconds
// while its pixels came at `taken` (a camera taken / exposure times as sensitive as it says).
FrameResult add(CaptureSession& s, const std::string& room, const glm::dquat& world, int device,
                double heading = 0.0, double exposure = 0.02, double taken = 0.02) {
  const cv::Mat image = sim::ideal_view(probe(room), kCamera, world, taken);
  const glm::dquat sensor = glm::normalize(
      glm::angleAxis(glm::radians(-heading), glm::dvec3(0, 1, 0)) * world);
  return s.add_image(image, {0.0, exposure, 1.0, sensor}, device);
}

// The owner sweeps yaw [from, to) in two bands (pitch -10 and 25).
void sweep(CaptureSession& s, const std::string& room, double from, double to) {
  for (double pitch : {-10.0, 25.0})
    for (double yaw = from; yaw < to; yaw += 20.0) ASSERT_TRUE(add(s, room, view(yaw, pitch), 0).used);
}

double heading_of(const DeviceRegistration& r) {
  // The offset's turn about +Y: where it takes -Z.
  const glm::dvec3 f = r.offset * glm::dvec3(0, 0, -1);
  return glm::degrees(std::atan2(-f.x, -f.z));
}

}  // namespace

TEST(Registration, AContributorRegistersAtItsHeadingWhateverItIs) {
  for (const char* room : {"venice", "park"})
    for (double heading : {0.0, 37.0, 90.0, 180.0, -121.0}) {
      SCOPED_TRACE(std::string(room) + " heading " + std::to_string(heading));
      CaptureSession s(kCamera, CameraResponse::srgb(), options());
      sweep(s, room, 0.0, 360.0);
      const int phone = s.add_device(kCamera, CameraResponse::srgb(), false);
      EXPECT_EQ(phone, 1);
      EXPECT_FALSE(s.registration(phone).registered);
      // The first view fits but waits for a second to agree; the second registers and merges
      // the first.
      const FrameResult first = add(s, room, view(50.0, 5.0), phone, heading);
      EXPECT_FALSE(first.used);
      EXPECT_FALSE(first.registered);
      EXPECT_NE(first.skipped_reason.find("registering"), std::string::npos) << first.skipped_reason;
      const FrameResult second = add(s, room, view(60.0, 5.0), phone, heading);
      ASSERT_TRUE(second.used) << second.skipped_reason;
      EXPECT_TRUE(second.registered);
      EXPECT_EQ(second.waiting_merged, 1);
      const DeviceRegistration r = s.registration(phone);
      EXPECT_TRUE(r.registered);
      EXPECT_EQ(r.waiting, 0u);
      const double error = std::remainder(heading_of(r) - heading, 360.0);
      EXPECT_LT(std::abs(error), 0.5);
      // The tilt it found is none (the sensors share gravity).
      EXPECT_LT(angle_deg(r.offset, glm::angleAxis(glm::radians(heading), glm::dvec3(0, 1, 0))),
                0.6);
      // From now on its frames go in at their place.
      const FrameResult third = add(s, room, view(200.0, 40.0), phone, heading);
      EXPECT_TRUE(third.used);
      EXPECT_LT(angle_deg(third.orientation, view(200.0, 40.0)), 0.6);
    }
}

TEST(Registration, AnotherRoomIsNeverMergedAndTheMapIsUnharmed) {
  for (const auto& [room, other] : {std::pair{"venice", "park"}, std::pair{"park", "venice"}}) {
    SCOPED_TRACE(std::string(room) + " with frames of " + other);
    CaptureSession s(kCamera, CameraResponse::srgb(), options());
    sweep(s, room, 0.0, 360.0);
    const Accumulators before = s.accumulators();
    const int phone = s.add_device(kCamera, CameraResponse::srgb(), false);
    for (int k = 0; k < 24; ++k) {
      const FrameResult r = add(s, other, view(15.0 * k, 5.0 + 10.0 * (k % 3)), phone, 70.0);
      EXPECT_FALSE(r.used) << "frame " << k;
      EXPECT_FALSE(r.registered);
      EXPECT_FALSE(r.skipped_reason.empty());
    }
    EXPECT_FALSE(s.registration(phone).registered);
    EXPECT_EQ(s.registration(phone).waiting, 8u);  // the newest wait, no more
    const Accumulators after = s.accumulators();
    EXPECT_EQ(before.weight, after.weight);
    EXPECT_EQ(before.weighted_radiance, after.weighted_radiance);
  }
}

TEST(Registration, AViewOfWhatTheMapHasNotSeenWaitsUntilTheMapMeetsIt) {
  CaptureSession s(kCamera, CameraResponse::srgb(), options());
  sweep(s, "venice", 0.0, 160.0);
  const int phone = s.add_device(kCamera, CameraResponse::srgb(), false);
  // The contributor starts on the other side of the room: nothing to register against.
  for (double yaw : {250.0, 260.0}) {
    const FrameResult r = add(s, "venice", view(yaw, 0.0), phone, 140.0);
    EXPECT_FALSE(r.used);
    EXPECT_NE(r.skipped_reason.find("not registered"), std::string::npos) << r.skipped_reason;
  }
  const double coverage_before = s.coverage();
  // The owner's sweep reaches it; the contributor's next views register and bring the two
  // that waited with them.
  sweep(s, "venice", 160.0, 300.0);
  FrameResult r = add(s, "venice", view(255.0, 0.0), phone, 140.0);
  EXPECT_FALSE(r.used);
  r = add(s, "venice", view(258.0, 0.0), phone, 140.0);
  ASSERT_TRUE(r.used) << r.skipped_reason;
  EXPECT_EQ(r.waiting_merged, 3);
  EXPECT_GT(s.coverage(), coverage_before);
}

TEST(Registration, TwoPhonesCoverTheRoomInHalfTheViewsAndLightItAsOne) {
  const CaptureOptions o = options();
  // One phone's whole sweep.
  CaptureSession one(kCamera, CameraResponse::srgb(), o);
  sweep(one, "venice", 0.0, 360.0);
  // Two: the owner sweeps the first half and a bit; the contributor — 133 degrees off in
  // heading, its camera 1.6x as sensitive as it says — the second, starting where they meet.
  CaptureSession two(kCamera, CameraResponse::srgb(), o);
  sweep(two, "venice", 0.0, 200.0);
  const int phone = two.add_device(kCamera, CameraResponse::srgb(), false);
  int used = 0;
  for (double pitch : {-10.0, 25.0})
    for (double yaw = 180.0; yaw < 360.0; yaw += 20.0)
      used += add(two, "venice", view(yaw, pitch), phone, 133.0, 0.02, 0.032).used;
  EXPECT_GE(used, 16);  // all but the one that waited for the second view to agree (merged then)
  EXPECT_NEAR(two.registration(phone).radiance_scale, 1.0 / 1.6, 0.03);
  EXPECT_NEAR(two.coverage(), one.coverage(), 0.01);
  // The map's irradiance (SH bands 0-2) as one phone's, within half a point.
  const ShCoeffs a = sh_project(one.measured_environment(), 3),
                 b = sh_project(two.measured_environment(), 3);
  double diff = 0.0, norm = 0.0;
  for (std::size_t k = 0; k < a.c.size(); ++k)
    diff += glm::length(a.c[k] - b.c[k]), norm += glm::length(a.c[k]);
  EXPECT_LT(diff / norm, 0.005);
}

TEST(Registration, ARestoredRegistrationNeedsNoSearch) {
  CaptureSession s(kCamera, CameraResponse::srgb(), options());
  sweep(s, "venice", 0.0, 360.0);
  const int phone = s.add_device(kCamera, CameraResponse::srgb(), false);
  s.restore_registration(phone, glm::angleAxis(glm::radians(-75.0), glm::dvec3(0, 1, 0)), 0.5);
  const FrameResult r = add(s, "venice", view(10.0, 5.0), phone, -75.0, 0.02, 0.04);
  EXPECT_TRUE(r.used);
  EXPECT_LT(angle_deg(r.orientation, view(10.0, 5.0)), 0.1);
  EXPECT_THROW(s.restore_registration(0, glm::dquat(1, 0, 0, 0), 1.0), std::invalid_argument);
  EXPECT_THROW(s.restore_registration(phone, glm::dquat(2, 0, 0, 0), 1.0), std::invalid_argument);
  EXPECT_THROW(s.restore_registration(phone, glm::dquat(1, 0, 0, 0), 0.0), std::invalid_argument);
  EXPECT_THROW(s.add_image(cv::Mat(), {}, 7), std::invalid_argument);
}

TEST(Registration, TheHeadingSearchSaysWhyItRefuses) {
  CaptureSession s(kCamera, CameraResponse::srgb(), options());
  const int phone = s.add_device(kCamera, CameraResponse::srgb(), false);
  const FrameResult empty = add(s, "venice", view(0.0, 0.0), phone, 10.0);
  EXPECT_NE(empty.skipped_reason.find("the map is empty"), std::string::npos);
  // A blank grey room: every heading fits alike, so none is taken.
  EnvMap grey(EnvLayout::for_size(Projection::LatLong, 64));
  std::fill_n(grey.image.data(), std::size_t(grey.layout.texel_count()) * 3, 0.3f);
  const EnvSampler flat(grey);
  CaptureSession g(kCamera, CameraResponse::srgb(), options());
  for (double yaw = 0.0; yaw < 360.0; yaw += 20.0)
    g.add_image(sim::ideal_view(flat, kCamera, view(yaw, 0.0), 0.02), {0.0, 0.02, 1.0, view(yaw, 0.0)});
  const int p = g.add_device(kCamera, CameraResponse::srgb(), false);
  const FrameResult r = g.add_image(sim::ideal_view(flat, kCamera, view(40.0, 0.0), 0.02),
                                    {0.0, 0.02, 1.0, view(10.0, 0.0)}, p);
  EXPECT_FALSE(r.used);
  EXPECT_NE(r.skipped_reason.find("textured"), std::string::npos) << r.skipped_reason;
}
