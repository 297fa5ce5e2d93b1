// Hooks whose stop is already requested: a computation given them throws Cancelled at once.
#pragma once

#include <stop_token>

#include "arlight/lighting/lighting.hpp"

namespace arlight::test {

inline lighting::Hooks stopped_hooks() {
  std::stop_source stop;
  stop.request_stop();
  lighting::Hooks hooks;
  hooks.stop = stop.get_token();  // the token keeps the stop state alive
  return hooks;
}

}  // namespace arlight::test
