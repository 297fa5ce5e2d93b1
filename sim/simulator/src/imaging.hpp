// The simulated phone camera between scene radiance and 8-bit codes: auto-exposure, vignetting,
// sensor noise, clipping and the non-linear camera response (tutorial §4.1: a pixel value is
// f(E·Δt), f the camera response, which HDR merging has to invert).
#pragma once

#include <algorithm>
#include <array>
#include <cstdint>
#include <glm/vec3.hpp>
#include <vector>

#include "arlight/common/camera.hpp"
#include "arlight/common/image.hpp"
#include "arlight/common/response.hpp"

namespace arlight::sim {

// Exposure time (seconds) and analogue gain. Units follow protocol/RECORDING.md with a sensor
// scale of 1: linear value = radiance × exposure × gain, so radiance = linear / (exposure × gain).
struct ExposureSetting {
  double exposure = 1.0 / 60;
  double gain = 1;
  double product() const { return exposure * gain; }
};

inline constexpr double kMinExposure = 1.0 / 8000;  // seconds
inline constexpr double kMaxExposure = 1.0 / 30;    // a 30 fps video stream's longest
inline constexpr double kMaxGain = 64;
inline constexpr double kTargetGrey = 0.18;  // metering puts the mean luminance here
inline constexpr double kAeStep = 0.3;       // each frame moves 30% of the way (log space)

// One step of the auto-exposure: log(exposure × gain) for a frame whose view meters
// `metered_mean`, moving kAeStep of the way from the last frame's `log_product` to the target
// kTargetGrey / mean (the first frame starts at its target).
double auto_exposure_step(double log_product, double metered_mean, bool first);

// The mean luminance a phone meters in a view: `radiance(dir)` (dir a camera-space ray) on a
// kMeterCols x kMeterRows grid of pixel centres.
inline constexpr int kMeterCols = 16, kMeterRows = 12;
template <class Radiance>
double metered_mean(const PinholeCamera& camera, Radiance&& radiance) {
  const CameraIntrinsics& k = camera.intrinsics();
  double sum = 0;
  for (int gy = 0; gy < kMeterRows; ++gy)
    for (int gx = 0; gx < kMeterCols; ++gx) {
      const glm::dvec2 px((gx + 0.5) * k.width / kMeterCols - 0.5,
                          (gy + 0.5) * k.height / kMeterRows - 0.5);
      sum += luminance(glm::dvec3(radiance(camera.unproject(px))));
    }
  return sum / (kMeterCols * kMeterRows);
}

// Splits exposure × gain like a phone: exposure time first (within its range), gain for the
// rest (1..64); beyond that the frame is simply under- or over-exposed.
ExposureSetting split_exposure(double product);

// Per-frame settings from each frame's metered mean luminance: the target exposure × gain is
// kTargetGrey / mean, smoothed in log space (the first frame starts at its target). Disabled,
// every frame keeps the first frame's setting.
std::vector<ExposureSetting> auto_exposure(const std::vector<double>& metered_mean, bool enabled);

// n settings one stop apart centred on the metered exposure, gain 1 (for response calibration).
std::vector<ExposureSetting> bracket_exposures(double metered_mean, int n);


// round(255 · response.encode(x, c)) without evaluating the curve per pixel: the 255 code
// thresholds of each channel are found once by bisection over the floats; a lookup starts at
// the code of its bin's lower end and steps over the (rarely any) thresholds below x, so it
// gives exactly the code the curve gives.
class CodeEncoder {
 public:
  explicit CodeEncoder(const CameraResponse& response);
  std::uint8_t operator()(float x, int channel) const {
    const auto& t = thresholds_[std::size_t(channel)];
    x = x > 0.0f ? x : 0.0f;    // (NaN too)
    if (x >= 1.0f) return 255;  // every curve reaches code 255 at 1
    int code = bin_code_[std::size_t(channel)][std::size_t(x * kBins)];
    while (code < 255 && x >= t[std::size_t(code)]) ++code;
    return std::uint8_t(code);
  }

 private:
  static constexpr int kBins = 4096;
  std::array<std::array<float, 255>, 3> thresholds_{};  // [k - 1]: smallest x giving code >= k
  std::array<std::array<std::uint8_t, kBins>, 3> bin_code_{};  // code at each bin's lower end
};

struct SensorParams {
  double read_noise = 0.002;  // sigma, linear full-scale units; 0 makes a noiseless sensor
  double shot_noise = 1e-4;   // shot-noise variance per unit of gain × linear value
  double vignetting = 0.05;   // 1 - V r² (residual after the phone's lens-shading correction)
  std::uint64_t seed = 0;
  // A sensor of this read noise (0: no shot noise either) and vignetting.
  static SensorParams with(double read_noise, double vignetting, std::uint64_t seed) {
    return {read_noise, read_noise > 0 ? 1e-4 : 0.0, vignetting, seed};
  }
};

class Sensor {
 public:
  Sensor(const CameraIntrinsics& camera, const SensorParams& params,
         const CameraResponse& response);

  // Turns one row of scene radiance (RGB, `width` pixels) of frame `frame` into 8-bit BGR (as
  // OpenCV stores images): linear = radiance × exposure × gain × vignette, plus Gaussian read
  // and shot noise (from a hash of seed, frame and pixel), clipped to [0, 1], then encoded.
  void expose_row(std::uint64_t frame, int y, const glm::vec3* radiance,
                  const ExposureSetting& setting, std::uint8_t* bgr) const;

 private:
  int width_, height_;
  SensorParams params_;
  std::vector<float> vignette_;  // per pixel
  CodeEncoder encoder_;
};

}  // namespace arlight::sim
