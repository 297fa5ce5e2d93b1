// Camera response calibration from differently exposed frames of one view (tutorial §4.1;
// Kán used Robertson et al. [RBS99], thesis ch. 3), and per-device storage of the curves.
#pragma once

#include <filesystem>
#include <optional>
#include <span>
#include <string>
#include <string_view>

#include "arlight/common/response.hpp"

namespace cv {
class Mat;
}

namespace arlight::capture {

enum class CalibrationMethod { Robertson, Debevec };
std::optional<CalibrationMethod> parse_calibration_method(std::string_view name);

// Recovers the response from >= 2 8-bit BGR images of the same static view, with exposure
// times (exposure * gain) in seconds, via OpenCV's CalibrateRobertson or CalibrateDebevec. The
// curve is made non-decreasing and normalised so code 255 is 1. Throws InputError when the set
// cannot calibrate (too few images, different sizes, non-positive times, one exposure only).
CameraResponse calibrate_response(std::span<const cv::Mat> images,
                                  std::span<const double> exposure_times,
                                  CalibrationMethod method = CalibrationMethod::Robertson);

// RMS over codes [lo, hi] and channels of the relative difference between two curves' linear
// values, after scaling `b` by the least-squares factor that best matches `a` there (a curve is
// only known up to scale).
double response_rms_difference(const CameraResponse& a, const CameraResponse& b, int lo = 64,
                               int hi = 192);

// Per-device curves in a folder: DIR/<device id>.json. Device ids may hold letters, digits and
// . _ -; anything else is refused, so an id can never name a path outside the folder.
class ResponseStore {
 public:
  explicit ResponseStore(std::filesystem::path folder) : folder_(std::move(folder)) {}
  std::filesystem::path path_for(std::string_view device_id) const;      // throws InputError
  std::optional<CameraResponse> find(std::string_view device_id) const;  // InputError if damaged
  void save(std::string_view device_id, const CameraResponse& response) const;

 private:
  std::filesystem::path folder_;
};

}  // namespace arlight::capture
