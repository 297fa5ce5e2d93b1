// A simulated phone camera that renders each frame when asked, instead of a whole recording
// ahead of time (arlight-sim): views of a probe along a trajectory, through the same sensor
// (noise, vignetting, clipping, response) and auto-exposure, but one that takes requests. A
// client asks for a frame's exposure (arlightd's exposure advice, issue 16 §4) and the next frame
// is taken at it, so closed-loop tests run without hardware (arlight-client --source sim:PROBE).
#pragma once

#include <cstdint>
#include <filesystem>
#include <glm/gtc/quaternion.hpp>
#include <memory>
#include <opencv2/core/mat.hpp>
#include <optional>
#include <string>
#include <vector>

#include "arlight/common/camera.hpp"
#include "arlight/sim/guided_motion.hpp"
#include "arlight/sim/trajectory.hpp"

namespace arlight::sim {

struct LiveCameraOptions {
  int width = 640, height = 480;
  double hfov_deg = 60;
  double fps = 30;
  int frames = 300;  // the trajectory's length: frames / fps seconds
  TrajectoryKind trajectory = TrajectoryKind::Sweep;
  // Set: a user who turns to the views the daemon asks for (propose_view) instead of following
  // the trajectory; the start direction, rates and tremor are these (the seed is `seed`).
  std::optional<GuidedMotionParams> guided;
  std::string response = "srgb";  // srgb, filmic or a response JSON file
  double noise = 0.002;           // read noise sigma; 0 = a noiseless sensor
  double vignetting = 0.05;
  int jpeg_quality = 90;  // 0: no JPEG (LiveFrame::jpeg stays empty)
  std::uint64_t seed = 0;
};

struct LiveFrame {
  std::size_t index = 0;
  double time = 0;  // seconds since the first frame
  cv::Mat bgr;      // 8-bit BGR
  std::vector<std::uint8_t> jpeg;
  double exposure = 0, gain = 1;         // what the frame was taken at
  bool requested = false;                // at a requested exposure, not the auto-exposure's
  glm::dquat orientation{1, 0, 0, 0};    // camera -> world, exact
};

class LiveCamera {
 public:
  // Loads the probe; InputError for an unreadable probe or response file, bad options.
  LiveCamera(const std::filesystem::path& probe, const LiveCameraOptions& options = {});
  ~LiveCamera();
  LiveCamera(LiveCamera&&) noexcept;
  LiveCamera& operator=(LiveCamera&&) noexcept;

  CameraIntrinsics intrinsics() const;
  const LiveCameraOptions& options() const;
  // The next frame along the trajectory; std::nullopt after the last.
  std::optional<LiveFrame> next();
  // The next frame is taken at this exposure x gain (split like a phone: exposure time first,
  // gain for the rest, within the sensor's range); the auto-exposure resumes after it, where it
  // was. A value <= 0 cancels a request not taken yet.
  void request_exposure(double exposure_gain);
  // The view the daemon asks for (unit, world frame), known from the last frame's time on; the
  // guided user turns to it after their reaction time. Ignored without options.guided, and
  // InputError for a direction that is not one.
  void propose_view(const glm::dvec3& direction);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace arlight::sim
