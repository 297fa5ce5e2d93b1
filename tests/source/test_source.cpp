// arlight_source: replay of recordings (count, metadata, skipped frames, pacing), the V4L2
// source's errors without a webcam, intrinsics files and source specs (also a registered scheme).
#include <gtest/gtest.h>

#include <chrono>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <stdexcept>

#include "arlight/common/error.hpp"
#include "arlight/source/source.hpp"
#include "support/sim_cache.hpp"

namespace fs = std::filesystem;
using namespace arlight;
using namespace arlight::source;

namespace {

// A tiny simulated recording (8 frames, 64x48, 30 fps, with gyro drift so the orientations
// differ from frame to frame), copied to a fresh folder the test may damage.
fs::path tiny_recording(const std::string& name) {
  sim::SimOptions o;
  o.frames = 8, o.width = 64, o.height = 48, o.gyro_drift_deg_per_s = 3, o.seed = 5;
  const fs::path shared = test::simulated_recording("tiny", o);
  const fs::path dir = test::fresh_temp_dir("source_" + name + "_" + std::to_string(::getpid()));
  fs::copy(shared, dir / "rec", fs::copy_options::recursive);
  return dir / "rec";
}

std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const std::exception& e) {
    return e.what();
  }
  return "(no error)";
}

}  // namespace

TEST(ReplaySource, DeliversEveryFrameWithItsMetadata) {
  const fs::path rec = tiny_recording("all");
  const recording::Recording manifest = recording::read_recording(rec);
  ReplaySource src(rec);
  EXPECT_EQ(src.intrinsics().width, 64);
  EXPECT_EQ(src.device_id(), "arlight-sim");
  std::size_t n = 0;
  while (auto f = src.next()) {
    const recording::Frame& m = manifest.frames[f->index];
    EXPECT_EQ(f->index, n);
    EXPECT_EQ(f->bgr.cols, 64);
    EXPECT_EQ(f->bgr.rows, 48);
    EXPECT_EQ(f->bgr.type(), CV_8UC3);
    EXPECT_FALSE(f->jpeg.empty());
    EXPECT_DOUBLE_EQ(f->timestamp, n / 30.0);
    EXPECT_DOUBLE_EQ(f->timestamp, m.timestamp);
    EXPECT_DOUBLE_EQ(f->exposure, m.exposure);
    EXPECT_GT(f->exposure, 0);
    EXPECT_DOUBLE_EQ(f->gain, m.gain);
    ASSERT_TRUE(f->orientation.has_value());
    EXPECT_DOUBLE_EQ(f->orientation->w, m.orientation.w);
    EXPECT_DOUBLE_EQ(f->orientation->y, m.orientation.y);
    ++n;
  }
  EXPECT_EQ(n, 8u);
  EXPECT_EQ(src.skipped(), 0u);
  EXPECT_FALSE(src.next().has_value());  // stays at the end
  // The drift makes consecutive orientations differ: the source does not repeat one frame's.
  EXPECT_NE(manifest.frames[0].orientation, manifest.frames[7].orientation);
}

TEST(ReplaySource, SkipsProblemFramesAndKeepsTheOthers) {
  const fs::path rec = tiny_recording("problems");
  nlohmann::json j;
  std::ifstream(rec / "recording.json") >> j;
  j["frames"][1]["exposure"] = 0.0;                                   // not positive
  j["frames"][3]["orientation"] = nlohmann::json::array({2, 0, 0, 0});  // not a unit quaternion
  std::ofstream(rec / "recording.json") << j.dump();
  fs::remove(rec / j["frames"][5]["file"].get<std::string>());  // missing file
  {  // frame 6 replaced by a valid JPEG of the wrong size
    std::vector<std::uint8_t> small;
    ASSERT_TRUE(cv::imencode(".jpg", cv::Mat(10, 10, CV_8UC3, cv::Scalar(1, 2, 3)), small));
    std::ofstream(rec / j["frames"][6]["file"].get<std::string>(), std::ios::binary)
        .write(reinterpret_cast<const char*>(small.data()), std::streamsize(small.size()));
  }
  ReplaySource src(rec);
  std::vector<std::size_t> got;
  while (auto f = src.next()) got.push_back(f->index);
  EXPECT_EQ(got, (std::vector<std::size_t>{0, 2, 4, 7}));
  EXPECT_EQ(src.skipped(), 4u);
}

TEST(ReplaySource, RealtimePacesByTimestamps) {
  const fs::path rec = tiny_recording("pace");
  SourceOptions o;
  o.realtime = true;
  ReplaySource src(rec, o);
  const auto start = std::chrono::steady_clock::now();
  std::size_t n = 0;
  while (src.next()) ++n;
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  EXPECT_EQ(n, 8u);
  EXPECT_GE(s, 7 / 30.0 - 0.005);  // the last frame is due 7/30 s after the first
  EXPECT_LT(s, 7 / 30.0 + 1.0);
}

TEST(OpenSource, ReplaySpecOpensARecordingAndBadSpecsSayWhatIsAccepted) {
  const fs::path rec = tiny_recording("spec");
  auto src = open_source("replay:" + rec.string(), {});
  EXPECT_NE(src->describe().find("replay:"), std::string::npos);
  EXPECT_TRUE(src->next().has_value());
  const std::string e = error_of([] { open_source("webcam0", {}); });
  EXPECT_NE(e.find("webcam0"), std::string::npos) << e;
  EXPECT_NE(e.find("v4l2:/dev/videoN"), std::string::npos) << e;
  EXPECT_NE(e.find("replay:REC_FOLDER"), std::string::npos) << e;
  EXPECT_NE(error_of([] { open_source("v4l2:", {}); }).find("expected"), std::string::npos);
  // A folder that is not a recording: the recording reader's error names the manifest.
  const std::string r = error_of([] { open_source("replay:/nonexistent/rec", {}); });
  EXPECT_NE(r.find("/nonexistent/rec"), std::string::npos) << r;
}

// A scheme client/ does not link (the laboratory's sim:, sim/source) is registered by the program
// that links both: it opens its specs, and the error lists its form after the built-in ones.
TEST(OpenSource, ARegisteredSchemeOpensItsSpecsAndIsListed) {
  const fs::path rec = tiny_recording("scheme");
  const auto seen = std::make_shared<std::string>();
  register_source_scheme(
      "fake",
      [seen](const std::string& rest, const SourceOptions& o) -> std::unique_ptr<FrameSource> {
        *seen = rest;
        return std::make_unique<ReplaySource>(rest, o);
      },
      "fake:REC_FOLDER (a test's scheme)");
  auto src = open_source("fake:" + rec.string(), {});
  EXPECT_EQ(*seen, rec.string());
  EXPECT_TRUE(src->next().has_value());
  const std::string e = error_of([] { open_source("fake:", {}); });
  EXPECT_NE(e.find("expected v4l2:/dev/videoN (a webcam), replay:REC_FOLDER (a recording) or "
                   "fake:REC_FOLDER (a test's scheme)"),
            std::string::npos)
      << e;
  EXPECT_THROW(register_source_scheme("a:b", nullptr, ""), std::invalid_argument);
}

TEST(V4l2Source, AbsentDeviceIsNamed) {
  const std::string e = error_of([] { open_source("v4l2:/dev/video99", {}); });
  EXPECT_NE(e.find("/dev/video99"), std::string::npos) << e;
  EXPECT_NE(e.find("no such device"), std::string::npos) << e;
}

TEST(V4l2Source, NonDevicesAreNotCaptureDevices) {
  // A character device that is no V4L2 device, and a regular file.
  const std::string null = error_of([] { V4l2Source("/dev/null"); });
  EXPECT_NE(null.find("/dev/null"), std::string::npos) << null;
  EXPECT_NE(null.find("not a V4L2 capture device"), std::string::npos) << null;
  const fs::path file = test::fresh_temp_dir("v4l2_" + std::to_string(::getpid())) / "video0";
  std::ofstream(file) << "not a camera";
  const std::string reg = error_of([&] { V4l2Source(file.string()); });
  EXPECT_NE(reg.find(file.string()), std::string::npos) << reg;
  EXPECT_NE(reg.find("not a V4L2 capture device"), std::string::npos) << reg;
}

TEST(Intrinsics, ReadsOpenCvCalibrationFilesAndScalesThem) {
  const fs::path dir = test::fresh_temp_dir("intrinsics_" + std::to_string(::getpid()));
  const fs::path yml = dir / "cam.yml";
  {
    cv::FileStorage fs(yml.string(), cv::FileStorage::WRITE);
    fs << "image_width" << 1280 << "image_height" << 720;
    fs << "camera_matrix" << cv::Mat(cv::Matx33d(900, 0, 639.5, 0, 905, 359.5, 0, 0, 1));
    fs << "distortion_coefficients" << cv::Mat(cv::Matx<double, 1, 5>(0.1, -0.2, 0.001, 0.002, 0.05));
  }
  const CameraIntrinsics full = load_intrinsics(yml, 1280, 720);
  EXPECT_DOUBLE_EQ(full.fx, 900);
  EXPECT_DOUBLE_EQ(full.cy, 359.5);
  EXPECT_DOUBLE_EQ(full.distortion[0], 0.1);
  EXPECT_DOUBLE_EQ(full.distortion[4], 0.05);
  const CameraIntrinsics half = load_intrinsics(yml, 640, 360);  // binned: same aspect
  EXPECT_DOUBLE_EQ(half.fx, 450);
  EXPECT_DOUBLE_EQ(half.fy, 452.5);
  EXPECT_DOUBLE_EQ(half.cx, 319.5);
  EXPECT_DOUBLE_EQ(half.cy, 179.5);
  const std::string aspect = error_of([&] { load_intrinsics(yml, 640, 480); });
  EXPECT_NE(aspect.find("aspect ratio"), std::string::npos) << aspect;
  EXPECT_NE(aspect.find(yml.string()), std::string::npos) << aspect;

  const fs::path bad = dir / "bad.yml";
  {
    cv::FileStorage fs(bad.string(), cv::FileStorage::WRITE);
    fs << "distortion_coefficients" << cv::Mat(cv::Matx<double, 1, 4>(0, 0, 0, 0));
  }
  const std::string missing = error_of([&] { load_intrinsics(bad, 640, 480); });
  EXPECT_NE(missing.find("camera_matrix: missing"), std::string::npos) << missing;
  const std::string none = error_of([&] { load_intrinsics(dir / "none.yml", 640, 480); });
  EXPECT_NE(none.find("no such file"), std::string::npos) << none;
}
