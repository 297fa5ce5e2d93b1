// The client's per-frame pipeline (client/app) without the network: a simulated orbit around a
// marker in venice through FramePipeline with fixed lighting, checked against the simulator's
// truth — what is sent, when the object is drawn and with what, and where it lands.
#include <gtest/gtest.h>

#include <functional>
#include <opencv2/core.hpp>

#include "arlight/app/client_app.hpp"
#include "arlight/common/hdr_io.hpp"
#include "arlight/common/resample.hpp"
#include "arlight/common/sh.hpp"
#include "arlight/truth/truth.hpp"
#include "support/sim_cache.hpp"

namespace arlight {
namespace {

using client_app::FramePipeline;
using client_app::Lighting;

// Remembers what the pipeline sent.
class RecordingChannel final : public client_app::LightingChannel {
 public:
  explicit RecordingChannel(Lighting l) : lighting_(std::move(l)) {}
  void send_frame(std::uint64_t sequence, const FrameInfo& info, int width, int height,
                  std::span<const std::uint8_t> jpeg, int /*quality*/) override {
    sent.push_back({sequence, info, width, height, jpeg.size()});
  }
  Lighting lighting() const override { return lighting_; }
  struct Sent {
    std::uint64_t sequence;
    FrameInfo info;
    int width, height;
    std::size_t bytes;
  };
  std::vector<Sent> sent;
  Lighting lighting_;
};

struct Fixture {
  std::vector<source::SourceFrame> frames;
  CameraIntrinsics camera;
  recording::Truth truth;
  ShCoeffs sh;
};

const Fixture& fixture() {
  static const Fixture f = [] {
    Fixture fx;
    const auto rec = test::orbit_recording();
    source::ReplaySource src(rec);
    fx.camera = src.intrinsics();
    for (int i = 0; i < 24; ++i)
      if (auto frame = src.next()) fx.frames.push_back(std::move(*frame));
    fx.truth = *recording::read_truth(rec);
    fx.sh =
        sh_project(load_envmap(std::string(ARLIGHT_SOURCE_DIR) + "/data/probes/venice.exr").env, 3);
    return fx;
  }();
  return f;
}

client_app::PipelineOptions options(const Fixture& fx) {
  client_app::PipelineOptions o;
  o.camera = fx.camera;
  o.marker = {"DICT_4X4_50", 7, 0.2};
  o.true_pose = [&fx](std::size_t i) { return recording::camera_in_marker(fx.truth, i); };
  return o;
}

Lighting sh_lighting(const Fixture& fx) {
  Lighting l;
  l.sh = fx.sh;
  l.sh_version = 1;
  const DominantLight d = sh_dominant_light(fx.sh);
  l.dominant_direction = d.direction, l.dominant_colour = d.colour;
  return l;
}

double mean_abs_difference(const cv::Mat& a, const cv::Mat& b) {
  return cv::mean(cv::abs(a - b))[0] + cv::mean(cv::abs(b - a))[0];
}

TEST(ClientApp, SendsEveryPhoneFrameWithItsOrientationAndDrawsTheLitObjectOnTheMarker) {
  const Fixture& fx = fixture();
  render::GlContext gl = render::GlContext::headless();
  FramePipeline pipeline(options(fx), client_app::load_model("sphere"));
  RecordingChannel channel(sh_lighting(fx));
  cv::Mat out;
  client_app::RunStats stats;
  for (const source::SourceFrame& f : fx.frames) {
    const client_app::FrameReport r = pipeline.process(f, channel, out);
    stats.add(r, 0.0);
    ASSERT_EQ(out.size(), f.bgr.size());
    if (r.drawn) {
      EXPECT_EQ(r.lit_by, render::LightingSource::Sh);
      // The object covers part of the frame: the composite differs from the camera's image.
      EXPECT_GT(mean_abs_difference(out, f.bgr), 0.5) << "frame " << f.index;
    }
  }
  // Every frame of a phone (it has an IMU) goes to the server, numbered from 1, as recorded.
  ASSERT_EQ(channel.sent.size(), fx.frames.size());
  for (std::size_t i = 0; i < fx.frames.size(); ++i) {
    EXPECT_EQ(channel.sent[i].sequence, fx.frames[i].index + 1);
    EXPECT_EQ(channel.sent[i].info.orientation, *fx.frames[i].orientation);
    EXPECT_EQ(channel.sent[i].info.exposure, fx.frames[i].exposure);
    EXPECT_EQ(channel.sent[i].bytes, fx.frames[i].jpeg.size());  // forwarded, not re-encoded
  }
  EXPECT_GE(stats.tracked, fx.frames.size() - 2);
  EXPECT_GE(stats.lit_by_sh, fx.frames.size() - 4);
  EXPECT_EQ(stats.lit_by_maps, 0u);
  // Pose against the truth: the orbit's marker within a couple of centimetres and degrees.
  ASSERT_FALSE(stats.error_cm.empty());
  EXPECT_LT(client_app::median(stats.error_cm), 2.0);
  EXPECT_LT(client_app::median(stats.error_deg), 2.0);
}

TEST(ClientApp, MapsReplaceTheShAndNoLightingDrawsNothing) {
  const Fixture& fx = fixture();
  render::GlContext gl = render::GlContext::headless();
  cv::Mat out;
  {
    // Without lighting the pipeline tracks and sends but leaves every frame as it was.
    FramePipeline pipeline(options(fx), client_app::load_model("sphere"));
    RecordingChannel dark{Lighting{}};
    for (std::size_t i = 0; i < 8; ++i) {
      const client_app::FrameReport r = pipeline.process(fx.frames[i], dark, out);
      EXPECT_FALSE(r.drawn);
      EXPECT_EQ(cv::norm(out, fx.frames[i].bgr, cv::NORM_INF), 0.0) << "frame " << i << " changed";
    }
    EXPECT_EQ(dark.sent.size(), 8u);
  }
  FramePipeline pipeline(options(fx), client_app::load_model("sphere"));
  const EnvLayout layout = EnvLayout::for_size(Projection::AngleMap, 32);
  auto maps = std::make_shared<client::ReceivedMapSet>();
  maps->shininess = {1, 40};
  maps->maps = {EnvMap(layout), EnvMap(layout)};
  for (EnvMap& m : maps->maps) std::fill(m.image.data(), m.image.data() + 3 * 32 * 32, 0.5f);
  Lighting lit = sh_lighting(fx);
  lit.maps = maps, lit.maps_version = 1;
  RecordingChannel channel(lit);
  std::size_t by_maps = 0, drawn = 0;
  for (std::size_t i = 0; i < 8; ++i) {
    const client_app::FrameReport r = pipeline.process(fx.frames[i], channel, out);
    drawn += r.drawn;
    by_maps += r.drawn && r.lit_by == render::LightingSource::Maps;
  }
  EXPECT_GE(drawn, 4u);
  EXPECT_EQ(by_maps, drawn);  // a map set, once there, is what shades
}

TEST(ClientApp, AWebcamSendsNothingUntilTheMarkerGivesItAnOrientation) {
  const Fixture& fx = fixture();
  render::GlContext gl = render::GlContext::headless();
  FramePipeline pipeline(options(fx), client_app::load_model("sphere"));
  RecordingChannel channel(sh_lighting(fx));
  cv::Mat out;
  source::SourceFrame blank = fx.frames[0];  // a webcam: no IMU; the marker not in view yet
  blank.orientation.reset();
  blank.bgr = cv::Mat::zeros(blank.bgr.size(), blank.bgr.type());
  const client_app::FrameReport before = pipeline.process(blank, channel, out);
  EXPECT_FALSE(before.tracked);
  EXPECT_FALSE(before.sent);
  EXPECT_TRUE(channel.sent.empty());
  source::SourceFrame seen = fx.frames[1];
  seen.orientation.reset();
  const client_app::FrameReport after = pipeline.process(seen, channel, out);
  EXPECT_TRUE(after.tracked);
  EXPECT_TRUE(after.sent);
  ASSERT_EQ(channel.sent.size(), 1u);
  EXPECT_NEAR(glm::length(channel.sent[0].info.orientation), 1.0, 1e-9);
}

TEST(ClientApp, FlagValuesAreCheckedWithTheFlagNamed) {
  EXPECT_EQ(client_app::parse_marker("7,0.2").id, 7);
  EXPECT_DOUBLE_EQ(client_app::parse_marker("7,0.2").size_m, 0.2);
  EXPECT_FLOAT_EQ(client_app::parse_material("0.7,0.3,80").shininess, 80.0f);
  EXPECT_EQ(client_app::parse_tone("reinhard"), render::ToneMode::Reinhard);
  for (const char* bad : {"7", "7.5,0.2", "7,-1", "x,0.2"}) {
    try {
      client_app::parse_marker(bad);
      ADD_FAILURE() << bad << " accepted";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("--marker"), std::string::npos) << e.what();
    }
  }
  EXPECT_THROW(client_app::parse_material("0.5,0.5,0.5"), InputError);  // s < 1
  EXPECT_THROW(client_app::parse_tone("aces"), InputError);
  EXPECT_EQ(client_app::parse_shading("hemisphere-occlusion"),
            render::Shading::HemisphereOcclusion);
  EXPECT_STREQ(render::shading_name(client_app::parse_shading("maps")), "maps");
  try {
    client_app::parse_shading("phong");
    ADD_FAILURE() << "phong accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("--shading"), std::string::npos) << e.what();
  }
  EXPECT_EQ(client_app::parse_tone_options("camera,match"),
            std::pair(render::ToneMode::CameraMatched, render::ColourCorrection::Match));
  EXPECT_EQ(client_app::parse_tone_options("linear").second, render::ColourCorrection::None);
  for (const char* bad : {"camera,none", "camera,reinhard", "aces,match"})
    EXPECT_THROW(client_app::parse_tone_options(bad), InputError) << bad;
  EXPECT_FALSE(client_app::parse_glass("off"));
  EXPECT_EQ(client_app::parse_glass("live"), render::Refraction::LiveFrame);
  EXPECT_EQ(client_app::parse_glass("maps"), render::Refraction::Maps);
  EXPECT_FLOAT_EQ(client_app::glass_material(1.33, 640).ior, 1.33f);
  EXPECT_TRUE(client_app::glass_material(1.33, 640).transmissive());
  for (const auto& [flag, bad] :
       {std::pair{"--glass", std::function<void()>([] { client_app::parse_glass("crystal"); })},
        std::pair{"--ior", std::function<void()>([] { client_app::glass_material(0.5, 640); })}}) {
    try {
      bad();
      ADD_FAILURE() << flag << " accepted a bad value";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(flag), std::string::npos) << e.what();
    }
  }
  EXPECT_THROW(client_app::load_model("/nonexistent.glb"), InputError);
}

}  // namespace
}  // namespace arlight
