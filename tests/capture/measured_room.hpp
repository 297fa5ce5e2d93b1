// What the fill's and the uncertainty's tests measure rooms with: a probe resampled to a
// layout, a map measured where a predicate holds, and the first part of a sweep.
#pragma once

#include <cmath>
#include <numbers>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "arlight/capture/capture.hpp"
#include "arlight/capture/fill.hpp"
#include "arlight/common/hdr_io.hpp"
#include "arlight/common/resample.hpp"

namespace arlight::capture::testing {

inline EnvMap probe(const char* name, const EnvLayout& layout) {
  return resample(load_envmap(std::string(ARLIGHT_SOURCE_DIR) + "/data/probes/" + name).env,
                  layout);
}

// The accumulators of a map whose texels are measured where `seen(dir)` holds (weight 1).
struct Measured {
  std::vector<float> radiance, weight;
  MeasuredTexels texels() const { return {radiance, weight}; }
};
template <class Seen>
Measured measure(const EnvMap& env, Seen seen) {
  Measured m;
  m.radiance.assign(env.image.data(), env.image.data() + 3 * env.layout.texel_count());
  m.weight.assign(env.layout.texel_count(), 0.0f);
  for (int y = 0; y < env.layout.height(); ++y)
    for (int x = 0; x < env.layout.width(); ++x) {
      const std::size_t t = std::size_t(y) * env.layout.width() + x;
      if (env.layout.texel_valid(x, y) && seen(env.layout.texel_dir(x, y)))
        m.weight[t] = 1.0f;
      else
        std::fill_n(&m.radiance[3 * t], 3, 0.0f);
    }
  return m;
}

// The first part of a sweep: the horizon band (elevation within 25 degrees), from azimuth 0 to
// `degrees` (171 degrees: 20 % of the sphere).
inline auto horizon_band(double degrees) {
  return [degrees](const glm::dvec3& d) {
    const double az = std::atan2(d.x, -d.z) * 180.0 / std::numbers::pi;
    return std::abs(d.y) < std::sin(25.0 * std::numbers::pi / 180.0) && az >= 0.0 && az < degrees;
  };
}

}  // namespace arlight::capture::testing
