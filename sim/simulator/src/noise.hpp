// Deterministic noise for the simulator. Every random quantity is a hash of (seed, stream,
// index...), never the state of a shared generator, so a simulation gives the same bytes for
// the same arguments whatever the thread count and whatever order the pixels are computed in.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <vector>

namespace arlight::sim {

// What a hash is drawn for; part of every key so that streams never share values.
enum class Stream : std::uint64_t {
  PixelNoise = 1,
  OrientationNoise,
  GyroNoise,
  AccelNoise,
  DriftSign,
  HandheldJitter,
  HandheldWalk,
  OrbitWander,
};

// SplitMix64's finaliser: a bijective 64-bit mix with full avalanche.
constexpr std::uint64_t mix64(std::uint64_t z) {
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

constexpr std::uint64_t hash64(std::uint64_t seed, Stream stream, std::uint64_t a = 0,
                               std::uint64_t b = 0) {
  std::uint64_t h = mix64(seed + 0x9E3779B97F4A7C15ull);
  h = mix64(h ^ (std::uint64_t(stream) * 0xD1B54A32D192ED03ull));
  h = mix64(h ^ (a + 0x8CB92BA72F3D8DD7ull));
  return mix64(h ^ (b + 0xA0761D6478BD642Full));
}

// Standard normal deviates for per-pixel sensor noise, fast: the inverse normal CDF tabulated
// at 4096 points and interpolated, indexed by 21 random bits (three deviates per 64-bit hash).
// The tails are cut at about 3.5 sigma, which changes the variance by < 1%.
class NormalTable {
 public:
  static const NormalTable& get() {
    static const NormalTable table;
    return table;
  }
  // A deviate from the low 21 bits of `bits`.
  float operator()(std::uint64_t bits) const {
    const float p = (float(bits & 0x1FFFFFu) + 0.5f) * (float(kSize) / float(1u << 21)) - 0.5f;
    const float clamped = p < 0.0f ? 0.0f : (p > kSize - 1 ? float(kSize - 1) : p);
    const int i = int(clamped) < kSize - 1 ? int(clamped) : kSize - 2;
    const float f = clamped - float(i);
    return z_[i] + (z_[i + 1] - z_[i]) * f;
  }

 private:
  static constexpr int kSize = 4096;
  NormalTable() {
    for (int i = 0; i < kSize; ++i) {
      // z with Phi(z) = (i + 0.5) / kSize, by bisection of Phi(z) = erfc(-z / sqrt 2) / 2.
      const double target = (i + 0.5) / kSize;
      double lo = -10, hi = 10;
      for (int k = 0; k < 80; ++k) {
        const double mid = 0.5 * (lo + hi);
        (0.5 * std::erfc(-mid / std::numbers::sqrt2) < target ? lo : hi) = mid;
      }
      z_[i] = float(0.5 * (lo + hi));
    }
  }
  float z_[kSize];
};

// One standard normal deviate in double precision (for poses and IMU samples).
inline double normal(std::uint64_t h) {
  const double u1 = (double(h >> 11) + 0.5) * 0x1p-53;
  const double u2 = (double(mix64(h) >> 11) + 0.5) * 0x1p-53;
  return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * std::numbers::pi * u2);
}

// The hand tremor of a handheld phone: knots every kTremorKnotSeconds (tremor < ~2 Hz) of yaw,
// pitch and roll with these standard deviations (degrees), interpolated by smooth_knots.
constexpr double kTremorKnotSeconds = 0.2;
constexpr double kTremorDeg[3] = {1.5, 1.5, 0.7};

// Catmull-Rom through the knots (knot k at x = k): smooth, passes through every knot.
inline double smooth_knots(const std::vector<double>& knots, double x) {
  const int last = int(knots.size()) - 1;
  const int i = std::clamp(int(std::floor(x)), 0, last);
  const double f = std::clamp(x - i, 0.0, 1.0);
  auto k = [&](int j) { return knots[std::size_t(std::clamp(j, 0, last))]; };
  const double p0 = k(i - 1), p1 = k(i), p2 = k(i + 1), p3 = k(i + 2);
  return 0.5 * (2.0 * p1 + (p2 - p0) * f + (2.0 * p0 - 5.0 * p1 + 4.0 * p2 - p3) * f * f +
                (3.0 * p1 - p0 - 3.0 * p2 + p3) * f * f * f);
}

}  // namespace arlight::sim
