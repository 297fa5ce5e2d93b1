// Ground truth that the simulator (tools/arlight-sim) writes next to a recording, so that what
// a consumer reconstructs from the recording can be judged against what was really there: the
// exact camera poses, the sensor model's settings and the marker's pose. The format is the
// "truth/" section of protocol/RECORDING.md.
#pragma once

#include <filesystem>
#include <glm/gtc/quaternion.hpp>
#include <glm/vec3.hpp>
#include <optional>
#include <string>
#include <vector>

#include "arlight/common/pose.hpp"

namespace arlight::recording {

inline constexpr const char* kTruthFormatName = "arlight-truth";
inline constexpr int kTruthFormatVersion = 1;
inline constexpr const char* kTruthFolder = "truth";
inline constexpr const char* kTruthManifestName = "truth.json";  // inside REC/truth/

using Pose = arlight::Pose;  // common/: one type for the concept

// An ArUco marker. Its frame is OpenCV aruco's: origin at the marker's centre, x right and y up
// in the marker image, z out of the marker; `size_m` is the side of the black square.
struct MarkerTruth {
  std::string dictionary = "DICT_4X4_50";
  int id = 0;
  double size_m = 0;
  Pose pose;  // marker frame -> world
};

struct Truth {
  std::string probe;          // the probe file the simulator rendered
  double radiance_scale = 1;  // captured radiance / truth env radiance
  std::string response;       // camera response curve name
  double gyro_drift_deg_per_s = 0;
  std::vector<Pose> poses;  // exact camera pose (camera -> world) per recording frame
  std::optional<MarkerTruth> marker;
  // Per frame: all four marker corners in front of the camera and inside the image. Empty
  // without a marker, one entry per pose with one.
  std::vector<bool> marker_visible;
};

// Writes REC/truth/truth.json atomically (creating REC/truth/). Throws std::invalid_argument
// for a Truth that read_truth would refuse (e.g. marker_visible not matching poses).
void write_truth(const std::filesystem::path& rec_folder, const Truth& truth);

// Reads REC/truth/truth.json: std::nullopt when it is absent; InputError naming the file and
// the field (e.g. "poses[3].orientation: missing") when it is malformed.
std::optional<Truth> read_truth(const std::filesystem::path& rec_folder);

// The true camera pose of frame i in the marker's frame (inverse(marker -> world) * (camera ->
// world)), or std::nullopt when the truth has no marker, no pose i, or the marker is not in view.
std::optional<Pose> camera_in_marker(const Truth& truth, std::size_t i);

}  // namespace arlight::recording
