// A client's standing request for map sets (RequestMaps, protocol/PROTOCOL.md): which maps, at
// what size and projection, by which method. The session computes against it, the map-set
// stream sends it, a checkpoint keeps it for a resumed session.
#pragma once

#include <string>
#include <vector>

#include "arlight/common/projection.hpp"

namespace arlight::daemon {

struct MapRequest {
  std::vector<double> shininess;
  int size = 128;
  Projection projection = Projection::AngleMap;
  std::string method = "auto";
};

}  // namespace arlight::daemon
