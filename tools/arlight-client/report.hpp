// What arlight-client writes at the end of a run: the contact sheet and MP4 of the composited
// frames, and the JSON summary of timings, pose errors and the session.
#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>
#include <opencv2/core/mat.hpp>
#include <vector>

#include "arlight/app/client_app.hpp"
#include "arlight/truth/truth.hpp"

namespace arlight::client_app {

// The camera's pose in the marker frame for each frame of a simulated recording where the
// marker is in view (nothing without a truth or a marker).
std::function<std::optional<Pose>(std::size_t)> true_poses(std::optional<recording::Truth> truth);

// Where a run's results go: a line per frame on stdout, OUT/frames/NNNNNN.png, a contact sheet
// of eight drawn frames spread over the run, OUT/composited.mp4 when ffmpeg is installed, the
// JSON summary (timings, pose errors, the session) in OUT/client.json and/or JSON_PATH, and the
// summary line.
class RunOutput {
 public:
  RunOutput(std::filesystem::path out, std::filesystem::path json_path);
  // `light`: the newest lighting when the frame went (its stated error and next view).
  void add(const FrameReport& report, const cv::Mat& composited, const Lighting& light);
  void finish(const RunStats& stats, const LinkStats& link, const nlohmann::json& extra);

 private:
  std::filesystem::path out_, json_path_;
  std::vector<cv::Mat> drawn_;
  std::size_t written_ = 0;
};

}  // namespace arlight::client_app
