// Where the thin client's frames come from: a V4L2 webcam (libv4l2) or the replay of a
// recording (protocol/RECORDING.md). Every source hands out decoded BGR images with the
// metadata the lighting daemon needs (exposure, gain, timestamp and, where the device has an
// IMU, its orientation), and keeps the encoded JPEG when it had one so the client can forward
// it without re-encoding. client/source/README.md shows how to use it.
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <glm/gtc/quaternion.hpp>
#include <glm/vec3.hpp>
#include <memory>
#include <opencv2/core/mat.hpp>
#include <optional>
#include <string>
#include <vector>

#include "arlight/common/camera.hpp"
#include "arlight/protocol/recording.hpp"

namespace arlight::source {

struct SourceFrame {
  cv::Mat bgr;  // 8-bit BGR, the source's size
  // The encoded frame when the source had one (a replay, an MJPEG webcam), so the client can
  // forward it without re-encoding; empty otherwise (YUYV webcams).
  std::vector<std::uint8_t> jpeg;
  double timestamp = 0;  // seconds since the source's first frame
  double exposure = 0;   // exposure time in seconds; 0 when the source cannot tell
  double gain = 1;       // analogue gain (ISO / 100); 1 when the source cannot tell
  // Camera -> world rotation from the device's IMU (common/CONVENTIONS.md: camera x right,
  // y up, looking down -z; world +Y up). Webcams have none.
  std::optional<glm::dquat> orientation;
  // The frame's number in its source: the recording's frame index for a replay (so that
  // truth/ lines up, skipped frames leave gaps), a running count for a webcam.
  std::size_t index = 0;
  // Taken at an exposure asked for with request_exposure(), not the source's own.
  bool exposure_requested = false;
};

struct SourceOptions {
  // Replay: deliver frames at the pace of their timestamps (steady clock) instead of as fast
  // as they can be decoded.
  bool realtime = false;
  // V4L2: the requested size and rate (the device may pick the nearest it supports; the
  // source reports what it got), an optional calibration file (OpenCV FileStorage YAML/JSON
  // with camera_matrix and distortion_coefficients, as cv::calibrateCamera tools write), a
  // manual exposure time in seconds (nullopt: leave the device's auto exposure), and how long
  // next() waits for a frame before giving up.
  int width = 640, height = 480;
  double fps = 30;
  std::filesystem::path intrinsics_file;
  std::optional<double> exposure;
  double timeout_s = 2.0;
  // Sim: how many frames the trajectory lasts (at `fps`, `width` x `height`), and whether the
  // simulated user turns to the views arlightd proposes (propose_view) instead of sweeping.
  int frames = 300;
  bool guided = false;
};

class FrameSource {
 public:
  virtual ~FrameSource() = default;
  // The next frame, or std::nullopt at the end (a replay's last frame). Device failures raise
  // InputError naming the device.
  virtual std::optional<SourceFrame> next() = 0;
  virtual CameraIntrinsics intrinsics() const = 0;
  // Keys the per-device camera response curve on the server ("" when unknown).
  virtual std::string device_id() const = 0;
  // One line for logs: what this source is and what it negotiated.
  virtual std::string describe() const = 0;
  // Takes the next frame at this exposure x gain (seconds at gain 1: arlightd's exposure
  // advice, PROTOCOL.md), then returns to the source's own exposure; <= 0 cancels a request
  // not taken yet. Whether the source can (a recording cannot; a webcam whose exposure was
  // fixed with --exposure will not).
  virtual bool request_exposure(double /*exposure_gain*/) { return false; }
  // arlightd's next view (LightingUpdate.next_view, world frame): a source whose camera can be
  // turned there (a guided sim: source) does so; whether it can. A person holding a phone or
  // webcam is told by the page's guide instead.
  virtual bool propose_view(const glm::dvec3& /*direction*/) { return false; }
  // Frames come at the camera's pace, whether taken or not (a webcam, a replay in real time): a
  // frame not sent when due is gone, so a client keeps only a few in flight (issue 36 §1).
  // Otherwise the source waits for its reader and every frame may go.
  virtual bool live() const { return false; }
};

// Replays a recording folder: frames with a `problem`, or whose JPEG does not decode to the
// recording's size, are skipped with a logged reason.
class ReplaySource : public FrameSource {
 public:
  // Reads the manifest (InputError naming the file and field when the recording is unusable).
  ReplaySource(const std::filesystem::path& folder, const SourceOptions& options = {});
  ~ReplaySource() override;
  std::optional<SourceFrame> next() override;
  CameraIntrinsics intrinsics() const override;
  std::string device_id() const override;
  std::string describe() const override;
  bool live() const override;  // with SourceOptions::realtime
  const recording::Recording& recording() const;
  std::size_t skipped() const;  // frames skipped so far

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// A webcam through libv4l2: MJPEG, else YUYV (else libv4l2's BGR24 conversion) at the
// requested size, memory-mapped streaming. Construction raises InputError naming the device
// and what was tried: no such device, busy, not a V4L2 capture device, no supported format
// (listing what the device offered).
class V4l2Source : public FrameSource {
 public:
  V4l2Source(const std::string& device, const SourceOptions& options = {});
  ~V4l2Source() override;
  std::optional<SourceFrame> next() override;
  CameraIntrinsics intrinsics() const override;
  std::string device_id() const override;
  std::string describe() const override;
  // Switches the device to manual exposure (V4L2_CID_EXPOSURE_ABSOLUTE, within its range) for
  // one frame, then back to the auto mode it had. UVC cameras apply a new exposure a frame or
  // two late; the frames report the control's value, so arlightd sees what was asked for.
  bool request_exposure(double exposure_gain) override;
  bool live() const override { return true; }

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// Opens `v4l2:/dev/videoN`, `replay:REC_FOLDER` or `SCHEME:REST` of a registered scheme (below;
// `sim:PROBE.exr` once a program has called register_sim_source()); anything else is an
// InputError that says which forms are accepted.
std::unique_ptr<FrameSource> open_source(const std::string& spec, const SourceOptions& options);

// Opens a source of one scheme: `rest` is the spec after "SCHEME:" (never empty).
using SourceFactory = std::function<std::unique_ptr<FrameSource>(const std::string& rest,
                                                                 const SourceOptions& options)>;

// Teaches open_source a scheme beyond v4l2: and replay:, for sources client/ does not link: the
// laboratory's simulated phone (sim/source, `sim:PROBE.exr`) is registered at startup by the
// program that links both (arlight-client, through register_sim_source()). `usage` is the spec's
// form as open_source's error lists it, e.g. "sim:PROBE.exr (a simulated phone in that room)".
// Registering a scheme again replaces its factory and usage. `scheme` must be non-empty and free
// of ':' (std::invalid_argument otherwise). Safe to call from any thread, also while another
// opens a source.
void register_source_scheme(const std::string& scheme, SourceFactory factory, std::string usage);

// Reads a calibration (OpenCV FileStorage YAML/XML/JSON: camera_matrix 3x3, optional
// distortion_coefficients with 4, 5 or more entries of which the first five are used, optional
// image_width/image_height) for frames of width x height. A calibration taken at another size
// with the same aspect ratio is scaled; another aspect ratio is an InputError, as is a missing
// or malformed file.
CameraIntrinsics load_intrinsics(const std::filesystem::path& file, int width, int height);

}  // namespace arlight::source
