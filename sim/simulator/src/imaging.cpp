#include "imaging.hpp"

#include <algorithm>
#include <bit>
#include <cmath>

#include "noise.hpp"

namespace arlight::sim {

ExposureSetting split_exposure(double product) {
  ExposureSetting s;
  s.exposure = std::clamp(product, kMinExposure, kMaxExposure);
  s.gain = std::clamp(product / s.exposure, 1.0, kMaxGain);
  return s;
}

double auto_exposure_step(double log_product, double metered_mean, bool first) {
  // A black view would ask for infinite exposure; split_exposure's clamps stop it anyway.
  const double target = std::log(kTargetGrey / std::max(metered_mean, 1e-12));
  return first ? target : log_product + kAeStep * (target - log_product);
}

std::vector<ExposureSetting> auto_exposure(const std::vector<double>& metered_mean, bool enabled) {
  std::vector<ExposureSetting> out;
  double log_product = 0;
  for (std::size_t i = 0; i < metered_mean.size(); ++i) {
    if (i == 0 || enabled) log_product = auto_exposure_step(log_product, metered_mean[i], i == 0);
    out.push_back(split_exposure(std::exp(log_product)));
  }
  return out;
}

std::vector<ExposureSetting> bracket_exposures(double metered_mean, int n) {
  const double centre = kTargetGrey / std::max(metered_mean, 1e-12);
  std::vector<ExposureSetting> out;
  for (int k = 0; k < n; ++k) out.push_back({centre * std::exp2(k - 0.5 * (n - 1)), 1.0});
  return out;
}

CodeEncoder::CodeEncoder(const CameraResponse& response) {
  for (int c = 0; c < 3; ++c) {
    auto code = [&](float x) { return std::lround(255.0 * double(response.encode(x, c))); };
    for (int k = 1; k <= 255; ++k) {
      // Bisection over the bit patterns of the floats in [0, 1] (ordered like the values):
      // code(lo) < k <= code(hi); encode() is non-decreasing, so hi ends as the first float
      // giving code >= k.
      std::uint32_t lo = 0, hi = std::bit_cast<std::uint32_t>(1.0f);
      while (hi - lo > 1) {
        const std::uint32_t mid = lo + (hi - lo) / 2;
        (code(std::bit_cast<float>(mid)) >= k ? hi : lo) = mid;
      }
      thresholds_[std::size_t(c)][std::size_t(k - 1)] = std::bit_cast<float>(hi);
    }
    const auto& t = thresholds_[std::size_t(c)];
    for (int b = 0; b < kBins; ++b) {
      const float lower = float(b) / kBins;  // the smallest x that falls into bin b
      bin_code_[std::size_t(c)][std::size_t(b)] =
          std::uint8_t(std::upper_bound(t.begin(), t.end(), lower) - t.begin());
    }
  }
}

Sensor::Sensor(const CameraIntrinsics& camera, const SensorParams& params,
               const CameraResponse& response)
    : width_(camera.width), height_(camera.height), params_(params), encoder_(response) {
  const double half_diagonal = 0.5 * std::hypot(double(width_), double(height_));
  vignette_.resize(std::size_t(width_) * std::size_t(height_));
  for (int y = 0; y < height_; ++y)
    for (int x = 0; x < width_; ++x) {
      const double r = std::hypot(x - camera.cx, y - camera.cy) / half_diagonal;
      vignette_[std::size_t(y) * std::size_t(width_) + std::size_t(x)] =
          float(1.0 - params_.vignetting * r * r);
    }
}

void Sensor::expose_row(std::uint64_t frame, int y, const glm::vec3* radiance,
                        const ExposureSetting& setting, std::uint8_t* bgr) const {
  const float scale = float(setting.product());
  const bool noisy = params_.read_noise > 0;
  const float read_var = float(params_.read_noise * params_.read_noise);
  const float shot = float(params_.shot_noise * setting.gain);
  const float* vig = vignette_.data() + std::size_t(y) * std::size_t(width_);
  const NormalTable& normal = NormalTable::get();
  // The frame's key; a pixel's three deviates come from one mix of it with the pixel's index.
  const std::uint64_t key = hash64(params_.seed, Stream::PixelNoise, frame);
  for (int x = 0; x < width_; ++x) {
    const std::uint64_t pixel = std::uint64_t(y) * std::uint64_t(width_) + std::uint64_t(x);
    float n[3] = {0, 0, 0};
    if (noisy) {
      const std::uint64_t h = mix64(key ^ (pixel * 0x9E3779B97F4A7C15ull));
      n[0] = normal(h), n[1] = normal(h >> 21), n[2] = normal(h >> 42);
    }
    const glm::vec3 l = radiance[x] * (scale * vig[x]);
    for (int c = 0; c < 3; ++c) {
      float v = l[c];
      if (noisy) v += std::sqrt(read_var + shot * std::max(v, 0.0f)) * n[c];
      v = std::clamp(v, 0.0f, 1.0f);
      bgr[3 * x + (2 - c)] = encoder_(v, c);
    }
  }
}

}  // namespace arlight::sim
