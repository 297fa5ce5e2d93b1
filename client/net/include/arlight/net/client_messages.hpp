// The messages a client sends (protocol/PROTOCOL.md), built in one place for both clients: the
// native protocol client (client_net.cpp) and the page (client/web/src/web_client.cpp) only
// encode and send them.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "arlight/common/frame.hpp"
#include "arlight/common/geo.hpp"
#include "arlight/common/projection.hpp"
#include "arlight/protocol/wire.hpp"

namespace arlight::client {

wire::CameraFrame jpeg_frame(std::uint64_t sequence, const FrameInfo& info, int width, int height,
                             std::span<const std::uint8_t> jpeg);
wire::RequestMaps map_request(const std::vector<double>& shininess, int size, Projection projection,
                              const std::string& method = "auto");
// A GGX chain from face `face` (a power of two), `levels` levels (0: down to face 16), with up
// to `specular_lights` small, bright lights taken out of it and sent beside it (issue 51 §1; 0:
// the chain holds the whole room).
wire::RequestMaps ggx_request(int face, int levels = 0, int specular_lights = 0);
// The Location message for a place and a UTC time (seconds since 1970), north-referenced when
// the frames' heading is known against a compass (`north_offset_deg`, eastward from true
// north); std::invalid_argument for an offset outside [-180, 180].
wire::Location make_location(const GeoLocation& where, double utc_seconds,
                             std::optional<double> north_offset_deg);

}  // namespace arlight::client
