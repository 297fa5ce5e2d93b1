// A client's standing request for map sets (RequestMaps, protocol/PROTOCOL.md): the thesis's
// Phong maps (which shininess, at what size and projection, by which method) or a GGX chain
// (level 0's face, how many levels). The session computes against it, the map-set stream sends
// it, a checkpoint keeps it for a resumed session.
#pragma once

#include <string>
#include <vector>

#include "arlight/common/projection.hpp"
#include "arlight/protocol/wire.hpp"

namespace arlight::daemon {

struct MapRequest {
  std::vector<double> shininess;  // Phong
  int size = 128;                 // Phong: --size N of arlight-maps; Ggx: level 0's face
  Projection projection = Projection::AngleMap;  // Phong (a chain is cube maps)
  std::string method = "auto";                   // Phong
  wire::MapKind kind = wire::MapKind::Phong;
  int levels = 0;                 // Ggx: levels of the chain, each half the face before
  // Ggx: up to this many small, bright lights taken out of the chain's room and sent beside it
  // (split_specular_lights; wire::RequestMaps::specular_lights). 0: the chain is the whole room.
  int specular_lights = 0;

  // Ggx: the last level's face (the request checked: wire::ggx_level_count() > 0).
  int ggx_min_face() const {
    return size >> (wire::ggx_level_count(std::uint32_t(size), levels) - 1);
  }
};

}  // namespace arlight::daemon
