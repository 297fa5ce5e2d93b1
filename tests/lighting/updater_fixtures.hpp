// What the map updaters' tests share: hooks whose stop is already requested (a computation given
// them throws Cancelled at once), and venice reduced to a face-64 cube map, as the daemon's
// previews reduce the capture.
#pragma once

#include <filesystem>
#include <stop_token>

#include "arlight/common/hdr_io.hpp"
#include "arlight/common/resample.hpp"
#include "arlight/lighting/lighting.hpp"

namespace arlight::test {

inline EnvMap venice_cube64() {
  static const EnvMap env = resample(
      load_envmap((std::filesystem::path(ARLIGHT_SOURCE_DIR) / "data/probes/venice.exr").string())
          .env,
      EnvLayout::for_size(Projection::Cube, 64));
  return env;
}

inline lighting::Hooks stopped_hooks() {
  std::stop_source stop;
  stop.request_stop();
  lighting::Hooks hooks;
  hooks.stop = stop.get_token();  // the token keeps the stop state alive
  return hooks;
}

}  // namespace arlight::test
