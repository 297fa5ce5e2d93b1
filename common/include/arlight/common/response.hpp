// Camera response curves: how a camera maps linear exposure to 8-bit codes, and back (tutorial
// §4.1; thesis ch. 3 linearises frames before accumulating them). The simulator encodes with
// them, the capture library linearises with their inverse, the client's camera-matched tone
// mapping encodes virtual radiance the same way.
#pragma once

#include <array>
#include <filesystem>
#include <string>
#include <vector>

namespace arlight {

class CameraResponse {
 public:
  // IEC 61966-2-1 sRGB: what a camera with no calibration is assumed to do.
  static CameraResponse srgb();
  // A filmic S-curve (Narkowicz's ACES fit, normalized so 1 maps to 1, then sRGB-encoded):
  // what phone pipelines do to highlights.
  static CameraResponse filmic();
  // A measured curve: for each channel, the linear exposure of each of the 256 codes (as
  // cv::CalibrateRobertson / CalibrateDebevec return it), non-decreasing, relative scale.
  // Throws std::invalid_argument if a channel is not 256 finite, non-negative, non-decreasing
  // values with a positive top.
  static CameraResponse from_table(const std::array<std::vector<float>, 3>& linear_of_code);

  // Linear exposure of an 8-bit code in a channel (0..2), scaled so code 255 is 1.
  float linear(int code, int channel) const { return table_[channel][code]; }
  // The code value in [0, 1] (before quantisation) that linear exposure x produces; x > 1 clips.
  float encode(float x, int channel) const;

  std::string name() const { return name_; }

  // Per-device curves are stored as JSON {"response": name, "linear_of_code": [[256], [256],
  // [256]]}, written atomically. load() throws InputError naming the file and what is wrong.
  void save(const std::filesystem::path& path) const;
  static CameraResponse load(const std::filesystem::path& path);
  // "srgb", "filmic", or else a file for load(): what every --response flag takes.
  static CameraResponse named(const std::string& name_or_file);

 private:
  CameraResponse() = default;
  std::string name_;
  std::array<std::array<float, 256>, 3> table_{};  // linear exposure of each code, [255] = 1
  int kind_ = 0;                                   // 0 table, 1 sRGB, 2 filmic (exact encode)
};

}  // namespace arlight
