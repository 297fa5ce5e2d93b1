// Helpers shared by the common/ and lighting/ tests.
#pragma once

#include <cmath>
#include <glm/geometric.hpp>

#include "arlight/common/projection.hpp"

namespace arlight::test {

// An environment map whose every valid texel holds f(texel direction).
template <class F>
EnvMap env_from_function(const EnvLayout& l, F f) {
  EnvMap env(l);
  for (int y = 0; y < l.height(); ++y)
    for (int x = 0; x < l.width(); ++x)
      if (l.texel_valid(x, y)) env.image.set(x, y, f(l.texel_dir(x, y)));
  return env;
}

// `env` with every texel within `radius` of `centre` times `factor`; returns the share changed.
inline double scale_cap(EnvMap& env, glm::dvec3 centre, double radius, float factor) {
  const auto table = texel_table(env.layout);
  double share = 0.0;
  for (std::size_t i = 0; i < table->size(); ++i) {
    if (glm::dot(glm::dvec3(table->x[i], table->y[i], table->z[i]), centre) < std::cos(radius))
      continue;
    for (int c = 0; c < 3; ++c) env.image.data()[3 * std::size_t(table->index[i]) + c] *= factor;
    share += 1.0 / double(table->size());
  }
  return share;
}

}  // namespace arlight::test
