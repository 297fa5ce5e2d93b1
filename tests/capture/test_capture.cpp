// Unit tests of arlight_capture: linearisation and weights, projection geometry, accumulation,
// live SH, bad frames, rotation fitting, response calibration, per-device curves.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <glm/gtc/quaternion.hpp>
#include <numbers>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <random>

#include "align.hpp"
#include "arlight/capture/calibration.hpp"
#include "arlight/capture/capture.hpp"
#include "arlight/common/error.hpp"
#include "arlight/common/pose.hpp"
#include "drift_model.hpp"
#include "linearize.hpp"

using namespace arlight;
using namespace arlight::capture;
namespace fs = std::filesystem;

namespace {

constexpr double kPi = std::numbers::pi;

glm::dquat yaw_pitch(double yaw_deg, double pitch_deg) {
  return glm::angleAxis(glm::radians(yaw_deg), glm::dvec3(0, 1, 0)) *
         glm::angleAxis(glm::radians(pitch_deg), glm::dvec3(1, 0, 0));
}

CaptureOptions small_options(bool align = false) {
  CaptureOptions o;
  o.layout = EnvLayout::for_size(Projection::AngleMap, 128);
  o.align = align;
  return o;
}

FrameInfo info(double exposure, double gain, glm::dquat q) { return {0.0, exposure, gain, q}; }

double srgb_linear(int code) {
  const double c = code / 255.0;
  return c <= 0.04045 ? c / 12.92 : std::pow((c + 0.055) / 1.055, 2.4);
}

}  // namespace

TEST(CaptureWeights, DistrustClippedDarkAndBorderPixels) {
  EXPECT_EQ(code_weight(128), 1.0f);
  EXPECT_EQ(code_weight(0), 0.0f);
  EXPECT_LT(code_weight(10), 0.5f);
  EXPECT_GT(code_weight(10), 0.0f);
  EXPECT_LE(code_weight(255), 1e-3f);  // clipped: only a lower bound, kept as a last resort
  EXPECT_GT(code_weight(255), 0.0f);
  EXPECT_EQ(border_weight(320, 240, 640, 480), 1.0f);
  EXPECT_LT(border_weight(0, 240, 640, 480), 0.01f);
  EXPECT_LT(border_weight(320, 479, 640, 480), 0.01f);
  EXPECT_GT(border_weight(20, 240, 640, 480), border_weight(5, 240, 640, 480));
}

TEST(CaptureLinearize, RadianceIsInverseResponseOverExposureTimesGain) {
  const cv::Mat grey(48, 64, CV_8UC3, cv::Scalar(60, 128, 200));  // B, G, R codes
  const LinearFrame f = linearize(grey, CameraResponse::srgb(), 0.01 * 2.0, 4);
  ASSERT_EQ(f.width, 16);
  ASSERT_EQ(f.height, 12);
  const std::size_t centre = 6 * 16 + 8;
  const float w = f.weight[centre];
  ASSERT_GT(w, 0.9f);
  EXPECT_NEAR(f.weighted_radiance[3 * centre + 0] / w, srgb_linear(200) / 0.02, 1e-4);
  EXPECT_NEAR(f.weighted_radiance[3 * centre + 1] / w, srgb_linear(128) / 0.02, 1e-4);
  EXPECT_NEAR(f.weighted_radiance[3 * centre + 2] / w, srgb_linear(60) / 0.02, 1e-4);
  EXPECT_LT(f.weight[0], 0.5f * w);  // the corner block lies in the border ramp
}

TEST(CaptureSession, ConstantFramesGiveThatRadianceEverywhereTheySaw) {
  const CameraIntrinsics cam = CameraIntrinsics::from_fov(160, 120, 60);
  CaptureSession s(cam, CameraResponse::srgb(), small_options());
  const cv::Mat frame(120, 160, CV_8UC3, cv::Scalar(100, 100, 100));
  const double expected = srgb_linear(100) / (0.02 * 1.5);
  double last_coverage = 0;
  for (int k = 0; k < 6; ++k) {
    const FrameResult r = s.add_image(frame, info(0.02, 1.5, yaw_pitch(50.0 * k, 10)));
    ASSERT_TRUE(r.used) << r.skipped_reason;
    EXPECT_GT(r.texels_changed, 100u);
    EXPECT_GT(s.coverage(), last_coverage);
    last_coverage = s.coverage();
  }
  const EnvMap env = s.environment();
  const std::vector<float> w = s.weights();
  int covered = 0;
  for (std::size_t t = 0; t < w.size(); ++t) {
    if (w[t] <= 0.0f) continue;
    ++covered;
    for (int c = 0; c < 3; ++c) ASSERT_NEAR(env.image.data()[3 * t + c], expected, 1e-4 * expected);
  }
  EXPECT_GT(covered, 1000);
  // One 60 x 47 degree frame covers ~0.83 sr; six overlapping ones less than 6x that.
  EXPECT_GT(s.coverage(), 0.2);
  EXPECT_LT(s.coverage(), 6 * 0.85 / (4 * kPi));
}

TEST(CaptureSession, ABrightSpotLandsInTheTexelOfItsDirection) {
  const CameraIntrinsics cam = CameraIntrinsics::from_fov(320, 240, 60);
  CaptureOptions o = small_options();
  o.layout = EnvLayout::for_size(Projection::LatLong, 256);
  CaptureSession s(cam, CameraResponse::srgb(), o);
  cv::Mat frame(240, 320, CV_8UC3, cv::Scalar(30, 30, 30));
  const int u = 220, v = 80;  // block of 5x5 pixels centred here
  frame(cv::Rect(u - 2, v - 2, 5, 5)).setTo(cv::Scalar(240, 240, 240));
  const glm::dquat q = yaw_pitch(-35, 20);
  ASSERT_TRUE(s.add_image(frame, info(0.01, 1, q)).used);
  const EnvMap env = s.environment();
  int best_x = 0, best_y = 0;
  float best = -1;
  for (int y = 0; y < env.image.height(); ++y)
    for (int x = 0; x < env.image.width(); ++x)
      if (env.image.at(x, y).g > best) best = env.image.at(x, y).g, best_x = x, best_y = y;
  const glm::dvec3 truth = q * PinholeCamera(cam).unproject({u, v});
  const glm::dvec3 found = env.layout.texel_dir(best_x, best_y);
  const double texel = 2 * kPi / 512;  // lat-long 512 x 256
  EXPECT_LT(std::acos(std::min(1.0, glm::dot(truth, found))), 1.5 * texel);
}

TEST(CaptureSession, LiveShEqualsAFullProjectionOfTheMap) {
  const CameraIntrinsics cam = CameraIntrinsics::from_fov(160, 120, 70);
  CaptureSession s(cam, CameraResponse::srgb(), small_options());
  std::mt19937 rng(7);
  for (int k = 0; k < 8; ++k) {
    cv::Mat frame(120, 160, CV_8UC3);
    cv::randu(frame, cv::Scalar(20, 20, 20), cv::Scalar(230, 230, 230));
    ASSERT_TRUE(s.add_image(frame, info(0.01, 1, yaw_pitch(40.0 * k, 25.0 * (k % 3) - 25))).used);
  }
  const ShCoeffs full = sh_project(s.measured_environment(), 8);
  ASSERT_EQ(s.measured_sh().order, 8);
  double scale = 0;
  for (const auto& c : full.c)
    scale = std::max({scale, std::abs(c.x), std::abs(c.y), std::abs(c.z)});
  for (std::size_t k = 0; k < full.c.size(); ++k)
    for (int c = 0; c < 3; ++c)
      EXPECT_NEAR(s.measured_sh().c[k][c], full.c[k][c], 1e-5 * scale) << k;
}

TEST(CaptureSession, BadFramesAreSkippedWithAReasonAndChangeNothing) {
  const CameraIntrinsics cam = CameraIntrinsics::from_fov(160, 120, 60);
  CaptureSession s(cam, CameraResponse::srgb(), small_options());
  const cv::Mat good(120, 160, CV_8UC3, cv::Scalar(90, 120, 150));
  ASSERT_TRUE(s.add_image(good, info(0.01, 1, yaw_pitch(0, 0))).used);
  const Accumulators before = s.accumulators();
  const ShCoeffs sh_before = s.sh();

  const auto skipped = [&](const FrameResult& r, const std::string& words) {
    EXPECT_FALSE(r.used);
    EXPECT_NE(r.skipped_reason.find(words), std::string::npos) << r.skipped_reason;
  };
  const double nan = std::numeric_limits<double>::quiet_NaN();
  skipped(
      s.add_image(cv::Mat(100, 160, CV_8UC3, cv::Scalar(1, 2, 3)), info(0.01, 1, yaw_pitch(9, 0))),
      "160x100");
  skipped(s.add_image(good, info(0.0, 1, yaw_pitch(90, 0))), "exposure");
  skipped(s.add_image(good, info(0.01, -2, yaw_pitch(90, 0))), "gain");
  skipped(s.add_image(good, info(0.01, 1, glm::dquat(nan, 0, 0, 0))), "finite");
  skipped(s.add_image(good, info(0.01, 1, glm::dquat(2, 0, 0, 0))), "unit");
  const std::vector<std::uint8_t> garbage = {0xFF, 0xD8, 0xFF, 0x00, 0x12, 0xFF, 0xD9};
  skipped(s.add_encoded(garbage, info(0.01, 1, yaw_pitch(90, 0))), "decode");
  skipped(s.add_encoded({}, info(0.01, 1, yaw_pitch(90, 0))), "decode");
  // A valid JPEG cut short would decode with its missing rows grey: refused instead.
  std::vector<std::uint8_t> jpeg;
  cv::Mat noise(120, 160, CV_8UC3);
  cv::randu(noise, cv::Scalar(0, 0, 0), cv::Scalar(255, 255, 255));
  ASSERT_TRUE(cv::imencode(".jpg", noise, jpeg));
  std::vector<std::uint8_t> huge = jpeg;           // its header claims 60000 x 60000 pixels
  const std::uint8_t sof_marker[] = {0xFF, 0xC0};  // baseline start of frame
  const auto sof =
      std::search(huge.begin(), huge.end(), std::begin(sof_marker), std::end(sof_marker));
  ASSERT_NE(sof, huge.end());
  const std::size_t at = std::size_t(sof - huge.begin()) + 5;  // marker, length, precision
  huge[at] = huge[at + 2] = 0xEA, huge[at + 1] = huge[at + 3] = 0x60;
  skipped(s.add_encoded(huge, info(0.01, 1, yaw_pitch(90, 0))), "60000x60000");
  jpeg.resize(jpeg.size() / 2);
  skipped(s.add_encoded(jpeg, info(0.01, 1, yaw_pitch(90, 0))), "truncated");

  EXPECT_EQ(s.frames_used(), 1u);
  EXPECT_EQ(s.frames_added(), 10u);
  const Accumulators after = s.accumulators();
  EXPECT_EQ(after.weight, before.weight);
  EXPECT_EQ(after.weighted_radiance, before.weighted_radiance);
  for (std::size_t k = 0; k < sh_before.c.size(); ++k) EXPECT_EQ(s.sh().c[k], sh_before.c[k]);
}

TEST(CaptureSession, JpegFramesDecodeAndAccumulate) {
  const CameraIntrinsics cam = CameraIntrinsics::from_fov(160, 120, 60);
  CaptureSession s(cam, CameraResponse::srgb(), small_options());
  std::vector<std::uint8_t> jpeg;
  cv::imencode(".jpg", cv::Mat(120, 160, CV_8UC3, cv::Scalar(128, 128, 128)), jpeg,
               {cv::IMWRITE_JPEG_QUALITY, 95});
  const FrameResult r = s.add_encoded(jpeg, info(0.01, 1, yaw_pitch(10, 0)));
  ASSERT_TRUE(r.used) << r.skipped_reason;
  EXPECT_GT(r.decode_ms, 0.0);
  // The angle map's centre is -z, where the camera looks; its rim is +z, behind it.
  const EnvMap env = s.measured_environment();
  EXPECT_NEAR(env.image.at(64, 64).g, srgb_linear(128) / 0.01, 0.02 * srgb_linear(128) / 0.01);
  EXPECT_EQ(env.image.at(64, 1), glm::vec3(0.0f));
}

TEST(CaptureSession, RestoredAccumulatorsGiveTheSameMapShAndCoverage) {
  const CameraIntrinsics cam = CameraIntrinsics::from_fov(160, 120, 60);
  CaptureSession a(cam, CameraResponse::srgb(), small_options());
  for (int k = 0; k < 3; ++k) {
    cv::Mat frame(120, 160, CV_8UC3);
    cv::randu(frame, cv::Scalar(20, 20, 20), cv::Scalar(230, 230, 230));
    a.add_image(frame, info(0.01, 1, yaw_pitch(70.0 * k, 0)));
  }
  CaptureSession b(cam, CameraResponse::srgb(), small_options());
  b.restore(a.accumulators());
  EXPECT_NEAR(b.coverage(), a.coverage(), 1e-12);
  EXPECT_EQ(b.environment().image.storage(), a.environment().image.storage());
  for (std::size_t k = 0; k < a.sh().c.size(); ++k)
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(b.sh().c[k][c], a.sh().c[k][c], 1e-6);
  Accumulators bad = a.accumulators();
  bad.weight.pop_back();
  EXPECT_THROW(b.restore(bad), std::invalid_argument);
  bad = a.accumulators();
  bad.weighted_radiance[30] = std::numeric_limits<float>::infinity();
  EXPECT_THROW(b.restore(bad), std::invalid_argument);
}

TEST(CaptureSession, RefusesUnusableCamerasAndOptions) {
  EXPECT_THROW(CaptureSession(CameraIntrinsics{}, CameraResponse::srgb()), std::invalid_argument);
  CaptureOptions o;
  o.sh_order = 2;
  EXPECT_THROW(CaptureSession(CameraIntrinsics::from_fov(64, 48, 60), CameraResponse::srgb(), o),
               std::invalid_argument);
}

TEST(CaptureAlign, RotationFitRecoversAKnownRotationDespiteOutliers) {
  std::mt19937 rng(3);
  std::normal_distribution<double> n(0, 1);
  const glm::dmat3 truth =
      glm::mat3_cast(glm::angleAxis(0.03, glm::normalize(glm::dvec3(1, 2, 3))));
  std::vector<glm::dvec3> a, b;
  for (int i = 0; i < 100; ++i) {
    const glm::dvec3 d = glm::normalize(glm::dvec3(0.3 * n(rng), 0.3 * n(rng), -1));
    a.push_back(d);
    // 30 % wrong matches: some unrelated direction in the view.
    b.push_back(i % 10 < 3 ? glm::normalize(glm::dvec3(0.3 * n(rng), 0.3 * n(rng), -1))
                           : truth * d);
  }
  const RotationFit fit = robust_rotation(a, b, 0.002, 12);
  ASSERT_TRUE(fit.ok) << fit.why;
  EXPECT_GE(fit.inliers, 70);
  EXPECT_LE(fit.inliers, 72);  // the outliers stay out (one may fall within 2 mrad by chance)
  for (int c = 0; c < 3; ++c)
    for (int r = 0; r < 3; ++r) EXPECT_NEAR(fit.rotation[c][r], truth[c][r], 1e-9);
  // Too few pairs: no fit, and it says why.
  const RotationFit none = robust_rotation(std::span(a).first(5), std::span(b).first(5), 0.002, 12);
  EXPECT_FALSE(none.ok);
  EXPECT_NE(none.why.find("5 feature matches"), std::string::npos);
}

// A bracketed set of a noisy synthetic scene through the filmic curve: Robertson (Kán's choice,
// the default) recovers the curve (up to scale) within 2 % RMS over the mid-tones (codes
// 64-192); OpenCV's Debevec, with its 200 sampled pixels and smoothness term, within 5 %.
TEST(CaptureCalibration, RecoversTheFilmicCurveFromABracket) {
  const CameraResponse truth = CameraResponse::filmic();
  std::mt19937 rng(11);
  std::lognormal_distribution<float> radiance(0.0f, 1.2f);
  std::normal_distribution<float> noise(0.0f, 0.002f);
  cv::Mat scene(120, 160, CV_32FC3);
  for (int y = 0; y < scene.rows; ++y)
    for (int x = 0; x < scene.cols; ++x)
      scene.at<cv::Vec3f>(y, x) = {radiance(rng), radiance(rng), radiance(rng)};
  std::vector<cv::Mat> images;
  std::vector<double> times;
  for (int k = -4; k <= 3; ++k) {
    const double t = 0.05 * std::pow(2.0, k);
    cv::Mat im(scene.size(), CV_8UC3);
    for (int y = 0; y < scene.rows; ++y)
      for (int x = 0; x < scene.cols; ++x)
        for (int c = 0; c < 3; ++c) {
          const float lin =
              std::clamp(scene.at<cv::Vec3f>(y, x)[c] * float(t) + noise(rng), 0.0f, 1.0f);
          im.at<cv::Vec3b>(y, x)[2 - c] =
              cv::saturate_cast<uchar>(std::lround(255 * truth.encode(lin, c)));
        }
    images.push_back(im);
    times.push_back(t);
  }
  for (const auto method : {CalibrationMethod::Robertson, CalibrationMethod::Debevec}) {
    const CameraResponse found = calibrate_response(images, times, method);
    const double rms = response_rms_difference(truth, found);
    EXPECT_LT(rms, method == CalibrationMethod::Robertson ? 0.02 : 0.05) << int(method);
    // Against the wrong curve the same measure is large: it can tell curves apart.
    EXPECT_GT(response_rms_difference(CameraResponse::srgb(), found), 0.05) << int(method);
  }
  EXPECT_THROW(calibrate_response(std::span(images).first(1), std::span(times).first(1)),
               InputError);
  std::vector<double> same(times.size(), 0.01);
  EXPECT_THROW(calibrate_response(images, same), InputError);
}

TEST(CaptureCalibration, CurvesAreFiledPerDeviceAndIdsCannotEscape) {
  const fs::path dir = fs::temp_directory_path() / "arlight_response_store_test";
  fs::remove_all(dir);
  const ResponseStore store(dir);
  EXPECT_FALSE(store.find("pixel-7").has_value());
  store.save("pixel-7", CameraResponse::filmic());
  const auto back = store.find("pixel-7");
  ASSERT_TRUE(back.has_value());
  EXPECT_LT(response_rms_difference(CameraResponse::filmic(), *back), 1e-6);
  EXPECT_THROW(store.path_for("../etc/passwd"), InputError);
  EXPECT_THROW(store.path_for(""), InputError);
  EXPECT_THROW(store.path_for("a/b"), InputError);
  fs::remove_all(dir);
}

namespace arlight::capture {
namespace {

// A gyro whose heading drifts 0.8 deg/s about world +Y, measured by alignments every 0.1 s with
// 0.05 deg of noise: the model finds the rate, and between alignments it extrapolates.
TEST(DriftModel, FitsAConstantHeadingDriftAndExtrapolatesIt) {
  DriftModel model(0.6, 3.0);
  const double rate = glm::radians(0.8);
  std::mt19937 rng(7);
  std::normal_distribution<double> noise(0.0, glm::radians(0.05));
  const auto truth = [&](double t) { return glm::angleAxis(rate * t, glm::dvec3(0, 1, 0)); };
  EXPECT_EQ(model.predict(0.0), glm::dquat(1, 0, 0, 0));  // no drift known yet
  for (int k = 1; k <= 60; ++k) {
    const double t = 0.1 * k;
    model.predict(t);
    const glm::dquat measured = glm::angleAxis(noise(rng), glm::dvec3(1, 0, 0)) * truth(t);
    model.update(measured, t);
  }
  EXPECT_NEAR(glm::length(model.rate()), rate, 0.1 * rate);
  EXPECT_GT(model.rate().y, 0.0);
  // One second without alignments: the prediction follows the drift, not the last offset.
  const glm::dquat predicted = model.predict(7.0);
  EXPECT_LT(angle_deg(predicted, truth(7.0)), 0.15);
  EXPECT_GT(angle_deg(model.offset(), truth(6.0)), 0.5);
  // A step of more than 5 s (a pause) is not extrapolated.
  const glm::dquat before = model.offset();
  EXPECT_EQ(model.predict(20.0), before);
}

}  // namespace
}  // namespace arlight::capture

// Issue 16 §2: arlightd's capture layout, and carrying accumulators from one layout to another.
TEST(CaptureLayout, TheDaemonsLayoutIsACubeMapWithAboutTheAngleMapsTexels) {
  const EnvLayout l = capture_layout_for(512);
  EXPECT_EQ(l.projection(), Projection::Cube);
  EXPECT_EQ(l.face_size(), 192);
  EXPECT_NEAR(double(texel_table(l)->size()) /
                  double(texel_table(EnvLayout::for_size(Projection::AngleMap, 512))->size()),
              1.07, 0.01);
  EXPECT_EQ(capture_layout_for(8).face_size(), 8);
  // Its texels' solid angles sum to the sphere and vary at most 5.2x (an angle map's ~17x).
  const auto t = texel_table(l);
  double sum = 0, lo = 1e9, hi = 0;
  for (double w : t->solid_angle) sum += w, lo = std::min(lo, w), hi = std::max(hi, w);
  EXPECT_NEAR(sum, 4 * kPi, 1e-9);
  EXPECT_LT(hi / lo, 5.3);
}

TEST(CaptureLayout, AccumulatorsCarryOverToAnotherLayoutByDirection) {
  const CameraIntrinsics cam = CameraIntrinsics::from_fov(160, 120, 60);
  CaptureSession a(cam, CameraResponse::srgb(), small_options());  // angle map 128
  const cv::Mat frame(120, 160, CV_8UC3, cv::Scalar(60, 110, 170));
  ASSERT_TRUE(a.add_image(frame, info(0.01, 1, yaw_pitch(30, 10))).used);
  const EnvLayout cube = capture_layout_for(128);
  const Accumulators c = convert_accumulators(a.accumulators(), a.layout(), cube);
  CaptureOptions o = small_options();
  o.layout = cube;
  CaptureSession b(cam, CameraResponse::srgb(), o);
  b.restore(c);
  EXPECT_NEAR(b.coverage(), a.coverage(), 0.02 * a.coverage());
  // Where a saw the frame, b has its radiance.
  const EnvMap ea = a.measured_environment(), eb = b.measured_environment();
  const glm::dvec3 ahead = yaw_pitch(30, 10) * glm::dvec3(0, 0, -1);
  const glm::ivec2 pa = a.layout().dir_to_texel(ahead), pb = cube.dir_to_texel(ahead);
  EXPECT_EQ(eb.image.at(pb.x, pb.y), ea.image.at(pa.x, pa.y));
  EXPECT_GT(eb.image.at(pb.x, pb.y).x, 0.0f);
  // The same layout: unchanged; a size that does not fit: refused.
  EXPECT_EQ(convert_accumulators(c, cube, cube).weight, c.weight);
  EXPECT_THROW(convert_accumulators(c, a.layout(), cube), std::invalid_argument);
}
