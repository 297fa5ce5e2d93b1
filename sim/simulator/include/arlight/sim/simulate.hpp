// arlight-sim: what a phone would record standing inside an HDR environment map, with the
// ground truth next to it (tools/README.md; formats in protocol/RECORDING.md).
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "arlight/protocol/recording.hpp"
#include "arlight/sim/marker.hpp"
#include "arlight/sim/trajectory.hpp"

namespace arlight::sim {

struct SimOptions {
  std::filesystem::path env;  // the probe
  std::filesystem::path out;  // the recording folder
  int frames = 300;
  double fps = 30;
  int width = 640, height = 480;
  double hfov_deg = 60;
  TrajectoryKind trajectory = TrajectoryKind::Sweep;
  // Not empty: the camera's pose at each frame (`frames` of them) instead of the trajectory's,
  // slerped in between for the IMU: a path recorded elsewhere (arlight-sim --guided's, a user
  // turning to arlightd's proposed views).
  std::vector<Pose> path;
  std::string response = "srgb";  // srgb, filmic or a response JSON file
  bool auto_exposure = true;
  // > 0: every second frame is exposed this many stops below the auto-exposure (a capture
  // app's HDR mode, so that light sources are seen unclipped).
  double hdr_stops = 0;
  double gyro_drift_deg_per_s = 0;
  double noise = 0.002;  // read noise sigma; 0 = a noiseless sensor (no shot noise either)
  double vignetting = 0.05;
  int jpeg_quality = 90;
  std::optional<MarkerSpec> marker;
  std::uint64_t seed = 0;
  int bracket = 0;  // > 0: that many frames of one view, one stop apart
  // Also write the frames as a YUV4MPEG2 video here (Chromium's fake camera plays it to the
  // browser client). Its exposure is fixed at the first view's, as a browser locks it.
  std::filesystem::path y4m;
  // Where and when the phone was (the recording's "place": the sun for arlightd).
  std::optional<recording::RecordedPlace> place;
};

// Every option as one line of text, and when this simulator was built: two runs with the same
// description make the same bytes (a key for caches of simulated recordings).
std::string describe(const SimOptions& options);

// Renders the recording and its ground truth. Throws InputError for bad input (an unreadable
// probe or response file, an --out folder that is not a recording); returns the frame count.
int simulate(const SimOptions& options);

}  // namespace arlight::sim
