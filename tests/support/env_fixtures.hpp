// Helpers shared by the common/ tests.
#pragma once

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

}  // namespace arlight::test
