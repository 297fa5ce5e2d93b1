// The sun's position from place and time (dissertation §5.3.3), and its direction in the world
// frame. The dissertation called NREL's SPA with Bristol's constants; this uses libnova, the
// field's library (VSOP87 precessed to the date, nutation, aberration, sidereal time;
// Saemundsson's refraction with the observer's pressure and temperature).
#pragma once

#include <cstdint>
#include <glm/vec3.hpp>
#include <optional>

#include "arlight/common/geo.hpp"
#include "arlight/common/projection.hpp"

namespace arlight::capture {

struct Atmosphere {
  double pressure_hpa = 1013.25;  // at the observer (SPA's example: 820 hPa at 1830 m)
  double temperature_c = 10.0;
};

struct SunPosition {
  double zenith_deg = 0;            // apparent: with atmospheric refraction
  double geometric_zenith_deg = 0;  // without (what sunrise tables use: 90.8333 at sunrise)
  double azimuth_deg = 0;           // from true north, eastward: 0 N, 90 E, 180 S, [0, 360)
  double elevation_deg() const { return 90.0 - zenith_deg; }
};

// Where the sun is seen from `where` at `utc_seconds` (Unix time, UTC). Refraction is applied
// while the sun's upper limb is above the horizon (true elevation >= -0.8333 deg), as SPA does.
// std::invalid_argument for a place off the Earth (geo_location_error), a time that is not
// finite or not between the years 1000 and 3000, or an impossible atmosphere.
SunPosition sun_position(const GeoLocation& where, double utc_seconds, const Atmosphere& air = {});

// Unit vector towards the sun in the world frame (+X east, +Y up, -Z north: the frame of a
// north-referenced orientation sensor, W3C's absolute orientation turned +Y up).
// `north_offset_deg` is the azimuth of the orientation's north from true north, eastward: a
// phone's compass points to magnetic north, so its offset is the magnetic declination there
// (east positive), plus any compass error.
glm::dvec3 sun_direction_world(const SunPosition& sun, double north_offset_deg = 0.0);

// ---- the sun as a prior for the dominant light (issue 17) ----
// Outdoors the sun is clipped in nearly every frame: the map shows where it is but not how
// bright, and the SH's dominant light (bands 0-1) smears it with the sky. When the map's
// brightest compact light sits where place and time put the sun, it is the sun: its direction
// is then the predicted elevation (exact) at the map's azimuth (which also measures the
// compass's error). It is not trusted when nothing compact and bright is there (indoors, under
// clouds, or before the sweep has seen it), nor below the horizon.

// The brightest compact light of a map (texels never seen are 0 and count for nothing).
struct BrightRegion {
  // Luminance-weighted centroid of the texels over half the peak within 15 degrees of it.
  glm::dvec3 direction{0.0, 1.0, 0.0};
  double solid_angle_sr = 0;  // their solid angle
  double contrast = 0;        // their mean luminance over the map's mean (seen texels)
};
// nullopt for a map with nothing seen or nothing brighter than black.
std::optional<BrightRegion> brightest_region(const EnvMap& measured);

struct SunCheck {
  double elevation_tolerance_deg = 5.0;  // the sweep's orientation error plus the centroid's bias
  double azimuth_tolerance_deg = 30.0;   // with a north-referenced orientation: compass error
  double max_solid_angle_sr = 0.1;       // a sun (with its halo) is compact; an overcast sky not
  // And it stands out: the sun is ~10^4 x the sky's radiance; captured with exposure advice
  // (or HDR frames) it stays >= 100x the map's mean (park.exr: ~300x), a bright cloud or a
  // lit window ~10x (city.exr: 12x).
  double min_contrast = 30.0;
};

struct SunEstimate {
  SunState state = SunState::Unknown;
  glm::dvec3 direction{0.0};    // world frame, unit (0 for Unknown)
  double north_offset_deg = 0;  // what the direction was computed with (Confirmed: measured)
};

// `north_referenced`: the client's world -Z is (magnetic) north, offset from true north by
// `north_offset_deg` (sun_direction_world); otherwise its heading is arbitrary and only the
// elevation can be checked.
SunEstimate estimate_sun(const SunPosition& predicted, const std::optional<BrightRegion>& bright,
                         bool north_referenced, double north_offset_deg,
                         const SunCheck& check = {});

}  // namespace arlight::capture
