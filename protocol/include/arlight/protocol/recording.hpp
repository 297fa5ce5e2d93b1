// Recorded sensor streams: what a phone or webcam sent, frame by frame, so that captures can be
// replayed, simulated and judged. The format (a folder with a JSON manifest, JPEG frames and an
// optional IMU log) is specified in protocol/RECORDING.md.
#pragma once

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <glm/gtc/quaternion.hpp>
#include <glm/vec3.hpp>
#include <optional>
#include <string>
#include <vector>

#include "arlight/common/camera.hpp"
#include "arlight/common/frame.hpp"
#include "arlight/common/geo.hpp"

namespace arlight::recording {

inline constexpr int kFormatVersion = 1;
inline constexpr const char* kFormatName = "arlight-recording";
inline constexpr const char* kManifestName = "recording.json";
// Largest frame file a reader accepts (a 4K JPEG at top quality is ~5 MiB).
inline constexpr std::uintmax_t kMaxFrameBytes = 32u << 20;

// Pinhole intrinsics in pixels, OpenCV's convention (common/include/arlight/common/camera.hpp).
using CameraIntrinsics = arlight::CameraIntrinsics;

// A recorded frame: its FrameInfo (timestamp in seconds since the recording started, exposure
// time in seconds, analogue gain = ISO / 100, and the unit quaternion rotating camera
// coordinates — x right, y up, looking down -z — into the gravity-aligned world, +Y up), the
// image file and whether the frame is usable.
struct Frame : FrameInfo {
  std::string file;  // relative to the recording's folder, e.g. "frames/000000.jpg"
  // Empty when the frame is usable; otherwise why not (zero exposure, a quaternion that is not
  // a rotation, a missing or truncated image, ...). Readers keep such frames so consumers can
  // skip them with the reason; they never stop the rest of the recording from being read.
  std::string problem;
};

struct ImuSample {
  double timestamp = 0;   // seconds, same clock as the frames
  glm::dvec3 gyro{0.0};   // rad/s, camera coordinates as for Frame::orientation
  glm::dvec3 accel{0.0};  // m/s^2 specific force (gravity included), camera coordinates
};

// Where and when a recording was made (RECORDING.md "place"): what a client tells arlightd in a
// Location message, so the sun can be placed (dissertation §5.3.3).
struct RecordedPlace {
  GeoLocation where;
  double utc_seconds = 0;  // UTC (seconds since 1970) of timestamp 0
  // The orientations' world -Z is north, this many degrees east of true north (a compass);
  // nullopt: the heading is arbitrary.
  std::optional<double> north_offset_deg;
};

struct Recording {
  std::filesystem::path folder;
  int version = kFormatVersion;
  std::string device_id;  // optional; keys per-device camera response curves
  std::optional<RecordedPlace> place;  // optional
  CameraIntrinsics camera;
  std::vector<Frame> frames;
  std::vector<ImuSample> imu;  // optional raw IMU samples, timestamps non-decreasing
};

// Reads and checks a recording folder. Anything that makes the recording as a whole unusable
// (no or unparsable manifest, wrong format or a newer version, missing or mistyped fields, bad
// intrinsics, a malformed IMU log) raises InputError naming the file and the field; problems
// confined to one frame are recorded in that Frame's `problem`.
Recording read_recording(const std::filesystem::path& folder);

// The bytes of frame i's JPEG, checked again (size limit, JPEG start and end markers), or
// InputError naming the file.
std::vector<std::uint8_t> read_frame_bytes(const Recording& rec, std::size_t i);

// Reads a recording's frames in order the way every replayer does: frames with a problem, or
// whose file cannot be read (changed on disk since the manifest was read), are skipped and
// reported with the reason; with `realtime`, next() waits until each frame is due at the pace
// of the timestamps (steady clock, from the first frame it returns).
class FrameReader {
 public:
  using OnSkip = std::function<void(std::size_t index, const std::string& reason)>;
  explicit FrameReader(const Recording& rec, bool realtime = false, OnSkip on_skip = {});

  struct Item {
    std::size_t index = 0;  // into rec.frames
    const Frame* frame = nullptr;
    std::vector<std::uint8_t> jpeg;
  };
  std::optional<Item> next();
  std::size_t skipped() const { return skipped_; }
  // Reports frame `index` as skipped for a reason found after next() returned it (it does not
  // decode, say).
  void skip(std::size_t index, const std::string& reason);

 private:
  const Recording& rec_;
  bool realtime_;
  OnSkip on_skip_;
  std::size_t next_ = 0, skipped_ = 0;
  std::optional<std::chrono::steady_clock::time_point> start_;
  double first_timestamp_ = 0;
};

// Writes a recording frame by frame: images go to REC/frames/ as they are added, the manifest
// (and IMU log) when finish() is called, atomically (temporary file, then rename), so an
// interrupted writer leaves no manifest that claims missing frames.
class RecordingWriter {
 public:
  RecordingWriter(std::filesystem::path folder, const CameraIntrinsics& camera,
                  std::string device_id = {});
  // Stores the encoded JPEG and its metadata; returns the frame's index.
  std::size_t add_frame(const std::vector<std::uint8_t>& jpeg, double timestamp, double exposure,
                        double gain, const glm::dquat& orientation);
  void add_imu(const ImuSample& sample);
  void set_place(const RecordedPlace& place);
  void finish();
  const std::filesystem::path& folder() const { return folder_; }

 private:
  std::filesystem::path folder_;
  Recording rec_;
  bool finished_ = false;
};

}  // namespace arlight::recording
