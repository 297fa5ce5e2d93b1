// Recording format: round trips, and every kind of damage reported the way RECORDING.md says.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "arlight/common/error.hpp"
#include "arlight/protocol/recording.hpp"

namespace fs = std::filesystem;
using namespace arlight;
using namespace arlight::recording;

namespace {

fs::path temp_dir(const std::string& name) {
  const fs::path d = fs::temp_directory_path() / ("arlight_recording_test_" + name);
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

std::vector<std::uint8_t> jpeg(int w, int h, int value) {
  cv::Mat img(h, w, CV_8UC3, cv::Scalar(value, value / 2, 255 - value));
  std::vector<std::uint8_t> out;
  cv::imencode(".jpg", img, out);
  return out;
}

CameraIntrinsics camera() {
  CameraIntrinsics c;
  c.width = 64, c.height = 48, c.fx = 55.4, c.fy = 55.5, c.cx = 31.5, c.cy = 23.5;
  c.distortion = {0.1, -0.02, 0.001, 0.002, 0.003};
  return c;
}

// A three-frame recording with an IMU log.
fs::path make_recording(const std::string& name) {
  const fs::path dir = temp_dir(name);
  RecordingWriter w(dir, camera(), "test-phone");
  const glm::dquat q = glm::angleAxis(0.3, glm::normalize(glm::dvec3(0.2, 1.0, 0.1)));
  for (int i = 0; i < 3; ++i) w.add_frame(jpeg(64, 48, 40 * i), i / 30.0, 0.01 * (i + 1), 1.5, q);
  w.add_imu({0.001, {0.01, -0.02, 0.03}, {0.1, -9.81, 0.2}});
  w.add_imu({0.006, {0.02, -0.01, 0.0}, {0.0, -9.8, 0.1}});
  w.set_place({{39.742476, -105.1786, 1830.0}, 1438520580.25, 7.5});
  w.finish();
  return dir;
}

nlohmann::json manifest(const fs::path& dir) {
  return nlohmann::json::parse(std::ifstream(dir / kManifestName));
}
void save(const fs::path& dir, const nlohmann::json& j) {
  std::ofstream(dir / kManifestName) << j.dump(1);
}

// The InputError message of reading `dir`, or "" when it reads.
std::string read_error(const fs::path& dir) {
  try {
    read_recording(dir);
    return "";
  } catch (const InputError& e) {
    return e.what();
  }
}

}  // namespace

TEST(Recording, WriterAndReaderRoundTripEverything) {
  const fs::path dir = make_recording("roundtrip");
  const Recording r = read_recording(dir);
  EXPECT_EQ(r.version, kFormatVersion);
  EXPECT_EQ(r.device_id, "test-phone");
  EXPECT_EQ(r.camera.width, 64);
  EXPECT_EQ(r.camera.height, 48);
  EXPECT_EQ(r.camera.fx, 55.4);
  EXPECT_EQ(r.camera.cy, 23.5);
  EXPECT_EQ(r.camera.distortion[4], 0.003);
  ASSERT_EQ(r.frames.size(), 3u);
  const glm::dquat q = glm::angleAxis(0.3, glm::normalize(glm::dvec3(0.2, 1.0, 0.1)));
  for (int i = 0; i < 3; ++i) {
    const Frame& f = r.frames[std::size_t(i)];
    EXPECT_TRUE(f.problem.empty()) << f.problem;
    EXPECT_EQ(f.timestamp, i / 30.0);  // doubles survive the JSON exactly
    EXPECT_EQ(f.exposure, 0.01 * (i + 1));
    EXPECT_EQ(f.gain, 1.5);
    EXPECT_NEAR(std::abs(glm::dot(f.orientation, q)), 1.0, 1e-12);
    const std::vector<std::uint8_t> bytes = read_frame_bytes(r, std::size_t(i));
    EXPECT_EQ(bytes, jpeg(64, 48, 40 * i));
    const cv::Mat img = cv::imdecode(bytes, cv::IMREAD_COLOR);
    EXPECT_EQ(img.cols, 64);
  }
  ASSERT_EQ(r.imu.size(), 2u);
  EXPECT_EQ(r.imu[0].timestamp, 0.001);
  EXPECT_EQ(r.imu[0].accel.y, -9.81);
  EXPECT_EQ(r.imu[1].gyro.x, 0.02);
  ASSERT_TRUE(r.place);
  EXPECT_EQ(r.place->where, (GeoLocation{39.742476, -105.1786, 1830.0}));
  EXPECT_EQ(r.place->utc_seconds, 1438520580.25);
  EXPECT_EQ(r.place->north_offset_deg, 7.5);
}

TEST(Recording, UnfinishedWriterLeavesNoManifest) {
  const fs::path dir = temp_dir("unfinished");
  {
    RecordingWriter w(dir, camera());
    w.add_frame(jpeg(64, 48, 1), 0.0, 0.01, 1.0, glm::dquat(1, 0, 0, 0));
  }
  EXPECT_NE(read_error(dir).find("no such file"), std::string::npos) << read_error(dir);
}

TEST(Recording, WholeRecordingProblemsAreErrorsNamingTheField) {
  const fs::path dir = make_recording("broken");
  const nlohmann::json good = manifest(dir);
  struct Case {
    std::function<void(nlohmann::json&)> damage;
    std::string says;
  };
  const Case cases[] = {
      {[](auto& j) { j["format"] = "something-else"; }, "format"},
      {[](auto& j) { j["version"] = 2; }, "version: 2 is newer than this reader (1)"},
      {[](auto& j) { j["version"] = "1"; }, "version: expected a whole number"},
      {[](auto& j) { j.erase("camera"); }, "camera: missing"},
      {[](auto& j) { j["camera"]["fx"] = -3; }, "camera.fx: must be a positive number"},
      {[](auto& j) { j["camera"]["width"] = 0; }, "camera.width: 0 is outside 1..16384"},
      {[](auto& j) { j["camera"]["cx"] = 64.5; }, "camera.cx: outside the image"},
      {[](auto& j) {
         j["camera"]["distortion"] = {1, 2};
       },
       "camera.distortion"},
      {[](auto& j) { j["frames"] = 5; }, "frames: expected an array"},
      {[](auto& j) { j["frames"][1].erase("exposure"); }, "frames[1].exposure: missing"},
      {[](auto& j) { j["frames"][2]["file"] = "../../etc/passwd"; },
       "frames[2].file: must be a path inside"},
      {[](auto& j) {
         j["frames"][0]["orientation"] = {1, 0, 0};
       },
       "frames[0].orientation: expected [w, x, y, z]"},
      {[](auto& j) { j["imu"] = "/tmp/x.csv"; }, "imu: must be a path inside"},
      {[](auto& j) { j["place"]["latitude"] = 95; }, "place: latitude 95"},
      {[](auto& j) { j["place"].erase("utc_seconds"); }, "place.utc_seconds: missing"},
      {[](auto& j) { j["place"]["north_offset"] = 200; }, "place.north_offset: must be in"},
      {[](auto& j) { j["place"]["longitude"] = "west"; }, "place.longitude: expected a number"},
  };
  for (const Case& c : cases) {
    nlohmann::json j = good;
    c.damage(j);
    save(dir, j);
    const std::string e = read_error(dir);
    EXPECT_NE(e.find(c.says), std::string::npos) << "expected '" << c.says << "', got: " << e;
    EXPECT_NE(e.find(kManifestName), std::string::npos) << e;
  }
}

TEST(Recording, TruncatedOrMissingManifestIsAnError) {
  const fs::path dir = make_recording("truncated");
  std::string text;
  {
    std::ifstream in(dir / kManifestName);
    text.assign(std::istreambuf_iterator<char>(in), {});
  }
  for (std::size_t cut : {std::size_t(0), std::size_t(10), text.size() / 2, text.size() - 3}) {
    std::ofstream(dir / kManifestName) << text.substr(0, cut);
    EXPECT_NE(read_error(dir).find("not valid JSON"), std::string::npos)
        << cut << ": " << read_error(dir);
  }
  fs::remove(dir / kManifestName);
  EXPECT_NE(read_error(dir).find("no such file"), std::string::npos);
  EXPECT_NE(read_error(dir / "nowhere").find("recording folder"), std::string::npos);
}

TEST(Recording, OneBadFrameIsMarkedWithItsReasonAndTheOthersStayUsable) {
  const fs::path dir = make_recording("badframes");
  nlohmann::json j = manifest(dir);
  // Five more entries, each wrong in one way, pointing at copies of a good frame.
  for (int k = 0; k < 5; ++k) {
    fs::copy_file(dir / "frames/000000.jpg", dir / ("frames/bad" + std::to_string(k) + ".jpg"));
    nlohmann::json f = j["frames"][2];
    f["file"] = "frames/bad" + std::to_string(k) + ".jpg";
    f["timestamp"] = 1.0 + k;
    j["frames"].push_back(f);
  }
  j["frames"][3]["exposure"] = 0;
  j["frames"][4]["orientation"] = {nullptr, 0, 0, 0};  // how JSON writers spell NaN
  j["frames"][5]["orientation"] = {0.5, 0.5, 0, 0};
  j["frames"][6]["timestamp"] = 0.0;  // earlier than frame 5
  fs::resize_file(dir / "frames/bad4.jpg", fs::file_size(dir / "frames/bad4.jpg") - 7);
  fs::remove(dir / "frames/000001.jpg");
  save(dir, j);
  const Recording r = read_recording(dir);
  ASSERT_EQ(r.frames.size(), 8u);
  const std::pair<std::size_t, const char*> expect[] = {
      {0, ""},
      {1, "frames/000001.jpg is missing"},
      {2, ""},
      {3, "exposure is not a positive number"},
      {4, "orientation is not a unit quaternion"},
      {5, "orientation is not a unit quaternion"},
      {6, "timestamp goes back in time"},
      {7, "frames/bad4.jpg is truncated (no JPEG end marker)"},
  };
  for (const auto& [i, why] : expect) EXPECT_EQ(r.frames[i].problem, why) << "frame " << i;
  EXPECT_THROW(read_frame_bytes(r, 7), InputError);
  EXPECT_THROW(read_frame_bytes(r, 1), InputError);
  EXPECT_EQ(read_frame_bytes(r, 0).size(), fs::file_size(dir / "frames/000000.jpg"));
}

TEST(Recording, NotAJpegIsAFrameProblem) {
  const fs::path dir = make_recording("notjpeg");
  std::ofstream(dir / "frames/000002.jpg", std::ios::trunc) << "P6\n64 48\n255\n....";
  const Recording r = read_recording(dir);
  EXPECT_EQ(r.frames[2].problem, "frames/000002.jpg is not a JPEG");
}

TEST(Recording, MalformedImuLogIsAnErrorNamingTheLine) {
  const fs::path dir = make_recording("imu");
  const std::pair<const char*, const char*> cases[] = {
      {"# header\n0.1,1,2,3,4,5,6\n0.2,1,2,3\n", "line 3: expected 7 numbers"},
      {"0.1,1,2,3,4,5,6,7\n", "line 1: more than 7 values"},
      {"0.2,1,2,3,4,5,6\n0.1,1,2,3,4,5,6\n", "line 2: timestamp goes back"},
      {"0.1,1,2,nan,4,5,6\n", "line 1: expected 7 numbers"},
  };
  for (const auto& [text, says] : cases) {
    std::ofstream(dir / "imu.csv", std::ios::trunc) << text;
    const std::string e = read_error(dir);
    EXPECT_NE(e.find(says), std::string::npos) << text << " -> " << e;
    EXPECT_NE(e.find("imu.csv"), std::string::npos) << e;
  }
  fs::remove(dir / "imu.csv");
  EXPECT_NE(read_error(dir).find("imu.csv': cannot read the IMU log"), std::string::npos);
}
