// Fuzz target: a sensor recording as arlight-replay, arlight-capture and arlight-client read it.
// The input is three parts (fuzz_support.hpp): recording.json, imu.csv and frames/000000.jpg.
// read_recording must refuse a bad recording with an InputError; from one it accepts, every
// usable frame's bytes are read again (read_frame_bytes) the same way.
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "arlight/common/error.hpp"
#include "arlight/protocol/recording.hpp"
#include "fuzz_support.hpp"

using namespace arlight;
namespace fs = std::filesystem;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto parts = fuzz::split_parts(data, size, 3);
  const fs::path folder = fuzz::scratch() / "recording";
  fs::create_directories(folder / "frames");
  fuzz::write_file(folder / "recording.json", parts[0]);
  fuzz::write_file(folder / "imu.csv", parts[1]);
  fuzz::write_file(folder / "frames" / "000000.jpg", parts[2]);
  try {
    const recording::Recording rec = recording::read_recording(folder);
    for (std::size_t i = 0; i < rec.frames.size(); ++i) {
      if (!rec.frames[i].problem.empty()) continue;
      try {
        recording::read_frame_bytes(rec, i);
      } catch (const InputError& e) {
        fuzz::refused(e);
      }
    }
  } catch (const InputError& e) {
    fuzz::refused(e);
  }
  return 0;
}

FuzzSeeds arlight_fuzz_seeds() {
  const fs::path folder = fuzz::scratch() / "seed-recording";
  fs::remove_all(folder);
  std::vector<std::uint8_t> jpeg;
  cv::imencode(".jpg", cv::Mat(8, 8, CV_8UC3, cv::Scalar(40, 120, 200)), jpeg);
  recording::RecordingWriter writer(folder, CameraIntrinsics::from_fov(8, 8, 60), "phone-1");
  writer.add_frame(jpeg, 0.0, 1.0 / 60, 1.0, glm::dquat(1, 0, 0, 0));
  writer.add_frame(jpeg, 1.0 / 30, 1.0 / 60, 2.0, glm::normalize(glm::dquat(0.9, 0.1, 0.2, 0)));
  writer.add_imu({0.0, glm::dvec3(0.01, 0, 0), glm::dvec3(0, 9.81, 0)});
  writer.add_imu({0.01, glm::dvec3(0.02, 0, 0), glm::dvec3(0, 9.8, 0.1)});
  writer.finish();
  const std::string manifest = fuzz::read_file(folder / "recording.json");
  const std::string imu = fuzz::read_file(folder / "imu.csv");
  const std::string frame = fuzz::read_file(folder / "frames" / "000000.jpg");
  return {fuzz::join_parts({manifest, imu, frame}), fuzz::join_parts({manifest, "", frame})};
}
