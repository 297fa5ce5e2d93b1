#include "arlight/net/client_messages.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace arlight::client {

wire::CameraFrame jpeg_frame(std::uint64_t sequence, const FrameInfo& info, int width, int height,
                             std::span<const std::uint8_t> jpeg) {
  wire::CameraFrame f;
  f.sequence = sequence;
  f.info = info;
  f.format = wire::PixelFormat::Jpeg;
  f.width = std::uint32_t(width), f.height = std::uint32_t(height);
  f.data.assign(jpeg.begin(), jpeg.end());
  return f;
}

wire::RequestMaps map_request(const std::vector<double>& shininess, int size, Projection projection,
                              const std::string& method) {
  return wire::RequestMaps{std::vector<float>(shininess.begin(), shininess.end()),
                           std::uint32_t(size), projection, method};
}

wire::RequestMaps ggx_request(int face, int levels, int specular_lights) {
  wire::RequestMaps r;
  r.specular_lights = std::uint8_t(std::clamp(specular_lights, 0, 255));
  r.size = std::uint32_t(face);
  r.projection = Projection::Cube;
  r.kind = wire::MapKind::Ggx;
  r.levels = std::uint8_t(levels);
  return r;
}

wire::Location make_location(const GeoLocation& where, double utc_seconds,
                             std::optional<double> north_offset_deg) {
  if (north_offset_deg && !(std::abs(*north_offset_deg) <= 180.0))
    throw std::invalid_argument("the north offset must be in [-180, 180] degrees");
  wire::Location l;
  l.where = where;
  l.utc_seconds = utc_seconds;
  l.north_referenced = north_offset_deg.has_value();
  l.north_offset_deg = north_offset_deg.value_or(0.0);
  return l;
}

}  // namespace arlight::client
