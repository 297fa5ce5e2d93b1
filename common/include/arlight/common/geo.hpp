// A place on Earth: what a client may tell arlightd so it knows where the sun is (dissertation
// §5.3.3). Shared by the protocol (the Location message), the capture's sun prior and the
// clients (their flags parse it: number_list.hpp).
#pragma once

#include <cmath>
#include <cstdint>
#include <string>
#include <string_view>

namespace arlight {

// WGS84 latitude (north positive) and longitude (east positive) in degrees; altitude above sea
// level in metres.
struct GeoLocation {
  double latitude_deg = 0, longitude_deg = 0, altitude_m = 0;
  bool operator==(const GeoLocation&) const = default;
};

// "" when `g` is a place on Earth, else what is wrong with it.
inline std::string geo_location_error(const GeoLocation& g) {
  if (!std::isfinite(g.latitude_deg) || std::abs(g.latitude_deg) > 90.0)
    return "latitude " + std::to_string(g.latitude_deg) + " is not in [-90, 90]";
  if (!std::isfinite(g.longitude_deg) || std::abs(g.longitude_deg) > 180.0)
    return "longitude " + std::to_string(g.longitude_deg) + " is not in [-180, 180]";
  if (!std::isfinite(g.altitude_m) || g.altitude_m < -500.0 || g.altitude_m > 10000.0)
    return "altitude " + std::to_string(g.altitude_m) + " m is not in [-500, 10000]";
  return "";
}

// What arlightd knows of the sun (LightingUpdate.sun_state; server/capture's sun prior).
enum class SunState : std::uint8_t {
  Unknown = 0,       // no place and time
  BelowHorizon = 1,  // night: not a light
  Predicted = 2,     // from place and time only: the map shows no compact light there (yet)
  Confirmed = 3,     // the map's brightest compact light agrees: the dominant light is the sun
};

inline const char* sun_state_name(SunState s) {
  switch (s) {
    case SunState::Unknown:
      return "unknown";
    case SunState::BelowHorizon:
      return "below-horizon";
    case SunState::Predicted:
      return "predicted";
    case SunState::Confirmed:
      return "confirmed";
  }
  return "?";
}

}  // namespace arlight
