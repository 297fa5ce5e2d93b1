// Runs the real arlight-sim binary and checks its recordings against their ground truth; unit
// tests of the truth/ reader and writer (sim/truth/include/arlight/truth/truth.hpp).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <glm/geometric.hpp>
#include <nlohmann/json.hpp>
#include <numbers>
#include <opencv2/aruco.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "arlight/common/camera.hpp"
#include "arlight/common/error.hpp"
#include "arlight/common/hdr_io.hpp"
#include "arlight/common/pose.hpp"
#include "arlight/common/resample.hpp"
#include "arlight/common/response.hpp"
#include "arlight/protocol/recording.hpp"
#include "arlight/truth/truth.hpp"
#include "support/run_tool.hpp"

namespace fs = std::filesystem;
using namespace arlight;
using namespace arlight::recording;

namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

using test::RunResult;

RunResult run(const std::string& args) { return test::run_tool(ARLIGHT_SIM_EXE, args); }

fs::path temp_dir(const std::string& name) {
  fs::path d = fs::temp_directory_path() / ("arlight_sim_test_" + name);
  fs::remove_all(d);
  return d;
}

const std::string kProbe = std::string(ARLIGHT_SOURCE_DIR) + "/data/probes/venice.exr";

// Runs the simulator into a fresh folder and returns it; fails the test if it fails.
fs::path simulate(const std::string& name, const std::string& args) {
  const fs::path out = temp_dir(name);
  const RunResult r = run("--env " + kProbe + " --out " + out.string() + " " + args);
  EXPECT_EQ(r.status, 0) << r.output;
  return out;
}

cv::Mat decode(const Recording& rec, std::size_t i, int flags = cv::IMREAD_COLOR) {
  const std::vector<std::uint8_t> bytes = read_frame_bytes(rec, i);
  return cv::imdecode(bytes, flags);
}

std::string file_bytes(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), {}};
}

double srgb_to_linear(double c) {
  return c <= 0.04045 ? c / 12.92 : std::pow((c + 0.055) / 1.055, 2.4);
}


// Fraction of the sphere's solid angle that some pixel of some view lands in, on a 64x32
// lat-long grid.
double covered_fraction(const CameraIntrinsics& k, const std::vector<Pose>& poses) {
  const EnvLayout grid(Projection::LatLong, 64, 32);
  const PinholeCamera cam(k);
  std::vector<glm::dvec3> dirs;
  for (int y = 0; y < k.height; ++y)
    for (int x = 0; x < k.width; ++x) dirs.push_back(cam.unproject({double(x), double(y)}));
  std::vector<char> hit(grid.texel_count(), 0);
  for (const Pose& p : poses)
    for (const glm::dvec3& d : dirs) {
      const glm::ivec2 t = grid.dir_to_texel(p.orientation * d);
      hit[std::size_t(t.y) * 64 + std::size_t(t.x)] = 1;
    }
  double covered = 0;
  for (int y = 0; y < 32; ++y)
    for (int x = 0; x < 64; ++x)
      if (hit[std::size_t(y) * 64 + std::size_t(x)]) covered += grid.texel_solid_angle(x, y);
  return covered / (4.0 * std::numbers::pi);
}

}  // namespace

// --- the recording --------------------------------------------------------------------------

TEST(ArlightSim, WritesARecordingThatReadsBackWithItsTruth) {
  const fs::path out = simulate("basic", "--frames 12 --size 160x120 --fps 24");
  const Recording rec = read_recording(out);
  ASSERT_EQ(rec.frames.size(), 12u);
  EXPECT_EQ(rec.camera.width, 160);
  EXPECT_EQ(rec.camera.height, 120);
  const CameraIntrinsics want = CameraIntrinsics::from_fov(160, 120, 60);
  EXPECT_NEAR(rec.camera.fx, want.fx, 1e-9);
  EXPECT_NEAR(rec.camera.cy, want.cy, 1e-9);
  for (std::size_t i = 0; i < rec.frames.size(); ++i) {
    const Frame& f = rec.frames[i];
    EXPECT_EQ(f.problem, "") << i;
    EXPECT_NEAR(f.timestamp, double(i) / 24, 1e-12);
    EXPECT_GE(f.exposure, 1.0 / 8000 - 1e-15);
    EXPECT_LE(f.exposure, 1.0 / 30 + 1e-15);
    EXPECT_GE(f.gain, 1.0);
    EXPECT_LE(f.gain, 64.0);
    const cv::Mat img = decode(rec, i);
    ASSERT_FALSE(img.empty()) << i;
    EXPECT_EQ(img.cols, 160);
    EXPECT_EQ(img.rows, 120);
  }
  // IMU at 200 Hz over the 11/24 s between the first and the last frame.
  ASSERT_EQ(rec.imu.size(), std::size_t(std::floor(11.0 / 24 * 200)) + 1);
  EXPECT_NEAR(rec.imu[1].timestamp, 0.005, 1e-12);

  const auto truth = read_truth(out);
  ASSERT_TRUE(truth.has_value());
  EXPECT_EQ(truth->poses.size(), 12u);
  EXPECT_EQ(truth->radiance_scale, 1.0);
  EXPECT_EQ(truth->response, "srgb");
  EXPECT_FALSE(truth->marker.has_value());
  EXPECT_TRUE(truth->marker_visible.empty());
  // The first view looks forward (-Z), level.
  EXPECT_LT(angle_deg(truth->poses[0].orientation, glm::dquat(1, 0, 0, 0)), 1e-9);

  // truth/env.exr is the sanitized probe (half float) as a lat-long map.
  const LoadedEnvMap probe = load_envmap(kProbe);
  const LoadedEnvMap env = load_envmap(out / "truth" / "env.exr");
  ASSERT_EQ(env.env.layout, probe.env.layout);
  EXPECT_TRUE(env.info.sanitized.clean());
  double worst = 0;
  for (std::size_t i = 0; i < env.env.image.storage().size(); ++i) {
    const double a = env.env.image.storage()[i], b = probe.env.image.storage()[i];
    worst = std::max(worst, std::abs(a - b) / (1e-3 + std::abs(b)));
  }
  EXPECT_LT(worst, 2e-3);
  // ... and the response curve is saved for the consumer.
  const CameraResponse r = CameraResponse::load(out / "truth" / "response.json");
  EXPECT_NEAR(r.linear(128, 1), CameraResponse::srgb().linear(128, 1), 1e-6);
}

TEST(ArlightSim, AnyProjectionProbeGivesALatLongTruth) {
  // The probe as a cube map: the truth is lat-long (4N x 2N) and the same environment.
  const fs::path dir = temp_dir("cube_probe");
  fs::create_directories(dir);
  const EnvMap latlong = load_envmap(kProbe).env;
  const EnvMap cube = resample(latlong, EnvLayout::for_size(Projection::Cube, 64));
  ImageMetadata meta;
  meta.projection = Projection::Cube;
  write_exr(dir / "cube.exr", cube.image.view(), meta);
  const fs::path out = temp_dir("cube_rec");
  const RunResult r = run("--env " + (dir / "cube.exr").string() + " --out " + out.string() +
                          " --frames 2 --size 64x48");
  ASSERT_EQ(r.status, 0) << r.output;
  const LoadedEnvMap env = load_envmap(out / "truth" / "env.exr");
  EXPECT_EQ(env.env.layout, EnvLayout(Projection::LatLong, 256, 128));
  // The same mean radiance (solid-angle weighted) as the original lat-long probe.
  auto mean = [](const EnvMap& m) {
    double sum = 0;
    for (int y = 0; y < m.layout.height(); ++y)
      for (int x = 0; x < m.layout.width(); ++x)
        sum += m.layout.texel_solid_angle(x, y) * m.image.at(x, y).y;
    return sum / (4 * std::numbers::pi);
  };
  EXPECT_NEAR(mean(env.env) / mean(latlong), 1.0, 0.01);
  EXPECT_EQ(read_truth(out)->probe, (dir / "cube.exr").string());
}

TEST(ArlightSim, PixelsAreTheProbeSeenThroughTheTruthPose) {
  // No noise, no vignetting, fixed exposure, sRGB, JPEG 100: the centre of each frame,
  // linearised and divided by exposure x gain, is the probe's radiance in the direction the
  // true pose looks.
  const fs::path out = simulate("exact",
                                "--frames 24 --size 160x120 --noise 0 --vignetting 0 "
                                "--auto-exposure off --response srgb --jpeg-quality 100");
  const Recording rec = read_recording(out);
  const auto truth = read_truth(out);
  ASSERT_TRUE(truth.has_value());
  ASSERT_EQ(truth->poses.size(), rec.frames.size());
  const EnvSampler probe(load_envmap(kProbe).env);
  const PinholeCamera cam(rec.camera);
  int checked = 0;
  double worst = 0;
  for (std::size_t i = 0; i < rec.frames.size(); ++i) {
    const cv::Mat img = decode(rec, i);
    ASSERT_FALSE(img.empty());
    double lin[3] = {0, 0, 0};
    // The principal point (79.5, 59.5) lies between the four centre pixels.
    for (int y = 59; y <= 60; ++y)
      for (int x = 79; x <= 80; ++x)
        for (int c = 0; c < 3; ++c)
          lin[c] += 0.25 * srgb_to_linear(img.at<cv::Vec3b>(y, x)[2 - c] / 255.0);
    const double measured = luminance(lin[0], lin[1], lin[2]);
    const double code = 255.0 * std::pow(measured, 1 / 2.2);
    if (code < 50 || code > 245) continue;  // too coarsely quantised, or clipped
    // What the probe sends along the four pixels' rays of the true pose (their mean is the
    // value at the forward direction -z to first order).
    glm::dvec3 want(0.0);
    for (int y = 59; y <= 60; ++y)
      for (int x = 79; x <= 80; ++x)
        want +=
            0.25 * glm::dvec3(probe.sample(
                       truth->poses[i].orientation * cam.unproject({double(x), double(y)}), 0.0));
    const glm::dvec3 forward(probe.sample(truth->poses[i].orientation * glm::dvec3(0, 0, -1), 0.0));
    EXPECT_NEAR(luminance(glm::dvec3(want)) / luminance(glm::dvec3(forward)), 1.0,
                0.05);
    const double e = rec.frames[i].exposure * rec.frames[i].gain;
    const double ratio = measured / e / luminance(glm::dvec3(want));
    EXPECT_NEAR(ratio, 1.0, 0.03) << "frame " << i;
    worst = std::max(worst, std::abs(ratio - 1.0));
    ++checked;
  }
  EXPECT_GE(checked, 8);
  RecordProperty("frames_checked", checked);
  RecordProperty("worst_relative_error", std::to_string(worst));
  // The exposure is the first frame's throughout.
  for (const Frame& f : rec.frames)
    EXPECT_EQ(f.exposure * f.gain, rec.frames[0].exposure * rec.frames[0].gain);
}

TEST(ArlightSim, SameSeedSameBytesWhateverTheThreadsAndOtherSeedsOtherNoise) {
  const std::string args = "--frames 5 --size 160x120 --trajectory handheld --gyro-drift 1";
  const fs::path a = simulate("seed_a", args + " --seed 7 --threads 1");
  const fs::path b = simulate("seed_b", args + " --seed 7 --threads 3");
  const fs::path c = simulate("seed_c", args + " --seed 8");
  const Recording ra = read_recording(a), rc = read_recording(c);
  EXPECT_EQ(file_bytes(a / "recording.json"), file_bytes(b / "recording.json"));
  EXPECT_EQ(file_bytes(a / "imu.csv"), file_bytes(b / "imu.csv"));
  EXPECT_EQ(file_bytes(a / "truth" / "truth.json"), file_bytes(b / "truth" / "truth.json"));
  for (const Frame& f : ra.frames) {
    EXPECT_EQ(file_bytes(a / f.file), file_bytes(b / f.file)) << f.file;
    EXPECT_NE(file_bytes(a / f.file), file_bytes(c / f.file)) << f.file;
  }
  // Another seed: other noise (and other hand jitter), about the same picture.
  const cv::Mat ia = decode(ra, 0), ic = decode(rc, 0);
  cv::Mat diff;
  cv::absdiff(ia, ic, diff);
  const double mean_diff = cv::mean(diff)[0];
  EXPECT_GT(mean_diff, 0.2);
  EXPECT_LT(mean_diff, 20.0);
}

TEST(ArlightSim, SweepCoversTheWholeSphere) {
  // The trajectory depends on the field of view and aspect, not the resolution: 160x120 has
  // the default 640x480's poses.
  for (const auto& [frames, size] : {std::pair{300, "160x120"}, {120, "320x240"}}) {
    const fs::path out = simulate("sweep_" + std::to_string(frames),
                                  "--frames " + std::to_string(frames) + " --size " + size);
    const Recording rec = read_recording(out);
    const auto truth = read_truth(out);
    ASSERT_TRUE(truth.has_value());
    ASSERT_EQ(truth->poses.size(), std::size_t(frames));
    const double covered = covered_fraction(rec.camera, truth->poses);
    EXPECT_GE(covered, 0.995) << frames << " frames";
    RecordProperty("covered_" + std::to_string(frames), std::to_string(covered));
    // Landscape throughout: the camera's x axis stays horizontal (no roll).
    for (const Pose& p : truth->poses)
      EXPECT_NEAR((p.orientation * glm::dvec3(1, 0, 0)).y, 0.0, 1e-9);
    // It looks straight up and straight down at some point.
    double up = -1, down = 1;
    for (const Pose& p : truth->poses) {
      const double y = (p.orientation * glm::dvec3(0, 0, -1)).y;
      up = std::max(up, y), down = std::min(down, y);
    }
    EXPECT_GT(up, std::cos(5 * kDeg));
    EXPECT_LT(down, -std::cos(1e-3));
  }
  // The same check fails for a capture that does not turn around (the coverage can fail).
  const fs::path orbit = simulate("sweep_orbit", "--frames 30 --size 160x120 --trajectory orbit");
  EXPECT_LT(covered_fraction(read_recording(orbit).camera, read_truth(orbit)->poses), 0.7);
}

// poles-first: the same sweep after a look straight up and straight down (what a capture
// guide would ask first); the plain sweep starts at the horizon and looks up only later.
TEST(ArlightSim, PolesFirstSweepLooksUpAndDownBeforeTheBandsAndCoversTheSphere) {
  const auto extremes_of_first_fifth = [](const std::vector<Pose>& poses) {
    double up = -1, down = 1;
    for (std::size_t k = 0; k < poses.size() / 5; ++k) {
      const double y = (poses[k].orientation * glm::dvec3(0, 0, -1)).y;
      up = std::max(up, y), down = std::min(down, y);
    }
    return std::pair{up, down};
  };
  const fs::path poles =
      simulate("sweep_poles", "--frames 300 --size 160x120 --trajectory poles-first");
  const auto truth = read_truth(poles);
  ASSERT_TRUE(truth.has_value());
  EXPECT_GE(covered_fraction(read_recording(poles).camera, truth->poses), 0.995);
  const auto [up, down] = extremes_of_first_fifth(truth->poses);
  EXPECT_GT(up, std::cos(1 * kDeg));
  EXPECT_LT(down, -std::cos(1 * kDeg));
  const fs::path sweep = simulate("sweep_300", "--frames 300 --size 160x120");
  const auto [sweep_up, sweep_down] = extremes_of_first_fifth(read_truth(sweep)->poses);
  EXPECT_LT(sweep_up, std::sin(45 * kDeg));
  EXPECT_GT(sweep_down, -std::sin(45 * kDeg));
}

// top-down: straight up first (the ceiling or sky: most of a room's light), then down band by
// band, never looking up again, straight down at the end; the whole sphere is covered.
TEST(ArlightSim, TopDownSweepLooksUpFirstThenOnlyDownwardsAndCoversTheSphere) {
  const fs::path out =
      simulate("sweep_top_down", "--frames 300 --size 160x120 --trajectory top-down");
  const auto truth = read_truth(out);
  ASSERT_TRUE(truth.has_value());
  EXPECT_GE(covered_fraction(read_recording(out).camera, truth->poses), 0.995);
  std::vector<double> y;
  for (const Pose& p : truth->poses) y.push_back((p.orientation * glm::dvec3(0, 0, -1)).y);
  const auto top = std::size_t(std::max_element(y.begin(), y.end()) - y.begin());
  EXPECT_GT(y[top], std::cos(1 * kDeg));
  EXPECT_LT(top, y.size() / 10) << "straight up comes first";
  for (std::size_t k = top + 1; k < y.size(); ++k)
    ASSERT_LE(y[k], y[k - 1] + 1e-9) << "frame " << k << " looks up again";
  EXPECT_LT(y.back(), -std::cos(1 * kDeg));
  // Half-way through, the upper hemisphere is behind it and the lower one mostly ahead.
  EXPECT_LT(y[y.size() / 2], 0.5);
  EXPECT_GT(y[y.size() / 2], -0.5);
}

TEST(ArlightSim, GyroDriftTurnsTheRecordedHeadingAndTheImuAgrees) {
  const fs::path out =
      simulate("drift", "--frames 301 --fps 30 --size 64x48 --gyro-drift 0.5 --seed 3");
  const Recording rec = read_recording(out);
  const auto truth = read_truth(out);
  ASSERT_TRUE(truth.has_value());
  EXPECT_EQ(std::abs(truth->gyro_drift_deg_per_s), 0.5);
  const double duration = rec.frames.back().timestamp;
  ASSERT_NEAR(duration, 10.0, 1e-9);
  // Recorded vs true orientation at the last frame: 0.5 deg/s x 10 s, about world +Y.
  const glm::dquat& last = rec.frames.back().orientation;
  EXPECT_NEAR(angle_deg(last, truth->poses.back().orientation), 0.5 * duration, 0.05 * duration);
  const glm::dquat rel = last * glm::conjugate(truth->poses.back().orientation);
  EXPECT_GT(std::abs(rel.y) / glm::length(glm::dvec3(rel.x, rel.y, rel.z)), 0.99)
      << "the drift is a heading drift";
  // Early frames are almost exact (only the 0.02-degree orientation noise).
  EXPECT_LT(angle_deg(rec.frames[0].orientation, truth->poses[0].orientation), 0.15);

  // The accelerometer reads gravity's reaction (+9.81 along world up) in camera coordinates.
  for (std::size_t i = 0; i < rec.frames.size(); i += 3) {
    const std::size_t k = std::size_t(std::lround(rec.frames[i].timestamp * 200));
    ASSERT_LT(k, rec.imu.size());
    ASSERT_NEAR(rec.imu[k].timestamp, rec.frames[i].timestamp, 1e-9);
    const glm::dvec3 up = glm::conjugate(truth->poses[i].orientation) * glm::dvec3(0, 9.81, 0);
    EXPECT_LT(glm::length(rec.imu[k].accel - up), 0.15) << "frame " << i;
  }
  // Integrating the gyro (true rate + drift + noise; camera coordinates) from the first
  // recorded orientation ends at the last one, drift included: a gyro in the wrong frame or
  // without the drift would miss by degrees.
  glm::dquat q = rec.frames.front().orientation;
  for (std::size_t k = 0; k + 1 < rec.imu.size(); ++k) {
    const double dt = rec.imu[k + 1].timestamp - rec.imu[k].timestamp;
    const glm::dvec3 &w0 = rec.imu[k].gyro, &w1 = rec.imu[k + 1].gyro;
    // Trapezoid plus the coning correction.
    const glm::dvec3 phi = 0.5 * (w0 + w1) * dt + glm::cross(w0, w1) * (dt * dt / 12.0);
    const double a = glm::length(phi);
    if (a > 0) q = q * glm::angleAxis(a, phi / a);
  }
  EXPECT_LT(angle_deg(q, last), 0.25 * 0.5 * duration);
  RecordProperty("imu_integration_error_deg", std::to_string(angle_deg(q, last)));
}

TEST(ArlightSim, MarkerIsDetectedWhereTheTruthPutsIt) {
  const fs::path out =
      simulate("marker", "--frames 16 --size 640x480 --trajectory orbit --marker 3,0.2");
  const Recording rec = read_recording(out);
  const auto truth = read_truth(out);
  ASSERT_TRUE(truth.has_value());
  ASSERT_TRUE(truth->marker.has_value());
  const MarkerTruth& m = *truth->marker;
  EXPECT_EQ(m.id, 3);
  EXPECT_EQ(m.size_m, 0.2);
  EXPECT_EQ(m.dictionary, "DICT_4X4_50");
  // Flat on the floor at the default point, facing up (+Y), its image's top towards -Z.
  EXPECT_NEAR(glm::length(m.pose.position - glm::dvec3(0, -1.2, -0.8)), 0.0, 1e-12);
  EXPECT_NEAR((m.pose.orientation * glm::dvec3(0, 0, 1)).y, 1.0, 1e-12);
  EXPECT_NEAR((m.pose.orientation * glm::dvec3(0, 1, 0)).z, -1.0, 1e-12);
  ASSERT_EQ(truth->marker_visible.size(), rec.frames.size());
  const auto visible = std::count(truth->marker_visible.begin(), truth->marker_visible.end(), true);
  EXPECT_GE(double(visible), 0.7 * double(rec.frames.size()));

  // The marker's corners in its own frame, in cv::aruco's order.
  const double h = 0.5 * m.size_m;
  const glm::dvec3 local[4] = {{-h, h, 0}, {h, h, 0}, {h, -h, 0}, {-h, -h, 0}};
  const PinholeCamera cam(rec.camera);
  const auto dict = cv::aruco::getPredefinedDictionary(cv::aruco::DICT_4X4_50);
  auto params = cv::aruco::DetectorParameters::create();
  params->cornerRefinementMethod = cv::aruco::CORNER_REFINE_SUBPIX;
  // A window smaller than the one-module white margin, so that the sheet's outer edge does not
  // pull the corners.
  params->cornerRefinementWinSize = 3;
  int detected = 0, corners_total = 0, corners_within_1px = 0;
  double sum = 0;
  for (std::size_t i = 0; i < rec.frames.size(); ++i) {
    if (!truth->marker_visible[i]) continue;
    const cv::Mat gray = decode(rec, i, cv::IMREAD_GRAYSCALE);
    std::vector<std::vector<cv::Point2f>> corners;
    std::vector<int> ids;
    cv::aruco::detectMarkers(gray, dict, corners, ids, params);
    const auto it = std::find(ids.begin(), ids.end(), 3);
    if (it == ids.end()) continue;
    ++detected;
    const Pose& camera = truth->poses[i];
    double frame_sum = 0;
    for (int c = 0; c < 4; ++c) {
      const glm::dvec3 world = m.pose.orientation * local[c] + m.pose.position;
      const auto px = cam.project(glm::conjugate(camera.orientation) * (world - camera.position));
      ASSERT_TRUE(px.has_value());
      const cv::Point2f got = corners[std::size_t(it - ids.begin())][std::size_t(c)];
      const double err = std::hypot(got.x - px->x, got.y - px->y);
      EXPECT_LT(err, 1.5) << "frame " << i << " corner " << c << ": detected (" << got.x << ", "
                          << got.y << "), truth (" << px->x << ", " << px->y << ")";
      frame_sum += err;
      corners_within_1px += err < 1.0;
      ++corners_total;
    }
    EXPECT_LT(frame_sum / 4, 1.0) << "frame " << i;
    sum += frame_sum;
  }
  EXPECT_GE(double(detected), 0.9 * double(visible));
  ASSERT_GT(corners_total, 0);
  // The detector's own error (sRGB edges, clipped white paper, JPEG, noise, oblique corners) is
  // a few tenths of a pixel; a truth off by half a pixel or more would not pass these.
  EXPECT_LT(sum / corners_total, 0.6);
  EXPECT_GE(double(corners_within_1px), 0.9 * corners_total);
  RecordProperty("mean_corner_error_px", std::to_string(sum / corners_total));
}

TEST(ArlightSim, HdrModeDarkensEverySecondFrameByTheStopsAsked) {
  const fs::path out =
      simulate("hdr", "--frames 8 --size 160x120 --auto-exposure off --hdr-stops 3");
  const Recording rec = read_recording(out);
  ASSERT_EQ(rec.frames.size(), 8u);
  const double normal = rec.frames[0].exposure * rec.frames[0].gain;
  for (std::size_t i = 0; i < 8; ++i)
    EXPECT_NEAR(rec.frames[i].exposure * rec.frames[i].gain, i % 2 ? normal / 8 : normal,
                1e-9 * normal)
        << i;
}

TEST(ArlightSim, BracketIsOneViewOneStopApart) {
  const fs::path out = simulate("bracket", "--bracket 7 --size 160x120 --frames 50");
  const Recording rec = read_recording(out);
  const auto truth = read_truth(out);
  ASSERT_EQ(rec.frames.size(), 7u);
  ASSERT_TRUE(truth.has_value());
  double last_mean = -1;
  for (std::size_t i = 0; i < 7; ++i) {
    EXPECT_EQ(truth->poses[i].orientation, truth->poses[0].orientation);
    EXPECT_LT(angle_deg(rec.frames[i].orientation, rec.frames[0].orientation), 0.2);
    EXPECT_EQ(rec.frames[i].gain, 1.0);
    if (i > 0) {
      EXPECT_NEAR(rec.frames[i].exposure / rec.frames[i - 1].exposure, 2.0, 1e-12);
    }
    // Brighter with every stop (until everything clips).
    const double mean = cv::mean(decode(rec, i))[1];
    if (last_mean < 250) {
      EXPECT_GT(mean, last_mean + 1) << i;
    }
    last_mean = mean;
  }
  // Level and forward: yaw 0, pitch 0.
  EXPECT_LT(angle_deg(truth->poses[0].orientation, glm::dquat(1, 0, 0, 0)), 1e-9);
}

// --- bad input ------------------------------------------------------------------------------

TEST(ArlightSim, BadInputExitsWithTwoAndOneLineSayingWhat) {
  const fs::path out = temp_dir("bad");
  const std::string base = "--out " + out.string() + " ";
  struct Case {
    std::string args, says;
  };
  const Case cases[] = {
      {base + "--env /nonexistent/probe.exr", "/nonexistent/probe.exr"},
      {base + "--env " + kProbe + " --size 10x", "--size"},
      {base + "--env " + kProbe + " --marker 3", "--marker"},
      {base + "--env " + kProbe + " --fov 180", "--fov"},
      {base + "--env " + kProbe + " --frames 0", "--frames"},
      {base + "--env " + kProbe + " --response /nonexistent/curve.json", "curve.json"},
      {base + "--env " + kProbe + " --frames abc", "--frames"},
      {"--env " + kProbe, "--out"},
  };
  for (const Case& c : cases) {
    const RunResult r = run(c.args);
    EXPECT_EQ(r.status, 2) << c.args << "\n" << r.output;
    EXPECT_NE(r.output.find(c.says), std::string::npos) << c.args << "\n" << r.output;
    EXPECT_EQ(std::count(r.output.begin(), r.output.end(), '\n'), 1) << r.output;
  }
  EXPECT_FALSE(fs::exists(out)) << "nothing is written for bad input";

  // A non-empty folder that is not a recording is refused and left alone ...
  fs::create_directories(out);
  { std::ofstream(out / "notes.txt") << "mine"; }
  const RunResult r = run(base + "--env " + kProbe + " --frames 2 --size 64x48");
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("not a recording"), std::string::npos) << r.output;
  EXPECT_EQ(file_bytes(out / "notes.txt"), "mine");
  // ... while an earlier recording is replaced, with no frames left over.
  const fs::path rec = simulate("rerun", "--frames 4 --size 64x48");
  const RunResult again =
      run("--env " + kProbe + " --out " + rec.string() + " --frames 2 --size 64x48");
  EXPECT_EQ(again.status, 0) << again.output;
  EXPECT_EQ(read_recording(rec).frames.size(), 2u);
  EXPECT_FALSE(fs::exists(rec / "frames" / "000003.jpg"));
}

// --- truth.json -----------------------------------------------------------------------------

namespace {

Truth sample_truth(bool with_marker) {
  Truth t;
  t.probe = "data/probes/venice.exr";
  t.radiance_scale = 1.0;
  t.response = "filmic";
  t.gyro_drift_deg_per_s = -0.3;
  for (int i = 0; i < 3; ++i)
    t.poses.push_back({glm::angleAxis(0.1 * i + 0.123456789, glm::normalize(glm::dvec3(1, 2, 3))),
                       {0.01 * i, -1.0 / 3, 1e-17}});
  if (with_marker) {
    t.marker = MarkerTruth{
        "DICT_4X4_50",
        7,
        0.15,
        {glm::angleAxis(-0.5 * std::numbers::pi, glm::dvec3(1, 0, 0)), {0.1, -1.2, -0.8}}};
    t.marker_visible = {true, false, true};
  }
  return t;
}

fs::path truth_json(const fs::path& rec) { return rec / "truth" / "truth.json"; }

void edit_json(const fs::path& file, const std::function<void(nlohmann::json&)>& edit) {
  nlohmann::json j = nlohmann::json::parse(std::ifstream(file));
  edit(j);
  std::ofstream(file) << j.dump();
}

std::string read_error(const fs::path& rec) {
  try {
    read_truth(rec);
  } catch (const InputError& e) {
    return e.what();
  }
  return "(no error)";
}

}  // namespace

TEST(Truth, RoundTripsExactly) {
  for (const bool with_marker : {false, true}) {
    const fs::path rec = temp_dir(with_marker ? "truth_marker" : "truth_plain");
    const Truth t = sample_truth(with_marker);
    write_truth(rec, t);
    const auto back = read_truth(rec);
    ASSERT_TRUE(back.has_value());
    EXPECT_EQ(back->probe, t.probe);
    EXPECT_EQ(back->radiance_scale, t.radiance_scale);
    EXPECT_EQ(back->response, t.response);
    EXPECT_EQ(back->gyro_drift_deg_per_s, t.gyro_drift_deg_per_s);
    ASSERT_EQ(back->poses.size(), t.poses.size());
    for (std::size_t i = 0; i < t.poses.size(); ++i) {
      EXPECT_EQ(back->poses[i].orientation, t.poses[i].orientation) << i;
      EXPECT_EQ(back->poses[i].position, t.poses[i].position) << i;
    }
    EXPECT_EQ(back->marker.has_value(), with_marker);
    if (with_marker) {
      EXPECT_EQ(back->marker->dictionary, "DICT_4X4_50");
      EXPECT_EQ(back->marker->id, 7);
      EXPECT_EQ(back->marker->size_m, 0.15);
      EXPECT_EQ(back->marker->pose.orientation, t.marker->pose.orientation);
      EXPECT_EQ(back->marker->pose.position, t.marker->pose.position);
    }
    EXPECT_EQ(back->marker_visible, t.marker_visible);
  }
}

TEST(Truth, AbsentIsNoTruthAndInconsistentIsRefusedOnWrite) {
  const fs::path rec = temp_dir("truth_absent");
  fs::create_directories(rec);
  EXPECT_FALSE(read_truth(rec).has_value());
  Truth t = sample_truth(true);
  t.marker_visible.pop_back();
  EXPECT_THROW(write_truth(rec, t), std::invalid_argument);
}

TEST(Truth, MalformedFieldsAreNamed) {
  const fs::path rec = temp_dir("truth_bad");
  struct Case {
    std::function<void(nlohmann::json&)> edit;
    std::string says;
  };
  const Case cases[] = {
      {[](nlohmann::json& j) { j["poses"][1].erase("orientation"); },
       "poses[1].orientation: missing"},
      {[](nlohmann::json& j) { j["marker"].erase("size_m"); }, "marker.size_m: missing"},
      {[](nlohmann::json& j) { j.erase("gyro_drift_deg_per_s"); }, "gyro_drift_deg_per_s: missing"},
      {[](nlohmann::json& j) {
         j["poses"][2]["position"] = {1, 2};
       },
       "poses[2].position"},
      {[](nlohmann::json& j) {
         j["poses"][0]["orientation"] = {1, 1, 0, 0};
       },
       "poses[0].orientation: not a unit quaternion"},
      {[](nlohmann::json& j) { j["marker_visible"].erase(0); }, "marker_visible"},
      {[](nlohmann::json& j) { j["marker"]["pose"].erase("position"); },
       "marker.pose.position: missing"},
      {[](nlohmann::json& j) { j["format"] = "something-else"; }, "format"},
      {[](nlohmann::json& j) { j["version"] = 99; }, "newer"},
  };
  for (const Case& c : cases) {
    write_truth(rec, sample_truth(true));
    edit_json(truth_json(rec), c.edit);
    const std::string err = read_error(rec);
    EXPECT_NE(err.find(c.says), std::string::npos) << err;
    EXPECT_NE(err.find("truth.json"), std::string::npos) << err;
  }
  // Truncated JSON.
  write_truth(rec, sample_truth(false));
  const std::string text = file_bytes(truth_json(rec));
  std::ofstream(truth_json(rec)) << text.substr(0, text.size() / 2);
  EXPECT_NE(read_error(rec).find("not valid JSON"), std::string::npos);
}
