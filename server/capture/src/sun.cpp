#include "arlight/capture/sun.hpp"

#include <libnova/dynamical_time.h>
#include <libnova/nutation.h>
#include <libnova/refraction.h>
#include <libnova/solar.h>
#include <libnova/transform.h>

#include <algorithm>
#include <cmath>
#include <glm/geometric.hpp>
#include <numbers>
#include <span>
#include <stdexcept>
#include <string>

#include "arlight/common/image.hpp"

namespace arlight::capture {

namespace {

constexpr double kUnixEpochJd = 2440587.5;  // Julian day of 1970-01-01 00:00 UTC
// The true elevation of the sun's centre when its upper limb touches the horizon: its
// semi-diameter (0.26667) plus the refraction there (0.5667); SPA's limit for refraction.
constexpr double kRefractionLimitDeg = -0.8333;

double radians(double deg) { return deg * std::numbers::pi / 180.0; }
double degrees(double rad) { return rad * 180.0 / std::numbers::pi; }

double elevation_deg(glm::dvec3 d) { return degrees(std::asin(std::clamp(d.y, -1.0, 1.0))); }
// Azimuth in the world frame: from -Z towards +X.
double world_azimuth_deg(glm::dvec3 d) { return degrees(std::atan2(d.x, -d.z)); }

double azimuth_difference_deg(double a, double b) {
  double d = std::fmod(a - b, 360.0);
  if (d > 180.0) d -= 360.0;
  if (d <= -180.0) d += 360.0;
  return d;
}

}  // namespace

SunPosition sun_position(const GeoLocation& where, double utc_seconds, const Atmosphere& air) {
  if (const std::string e = geo_location_error(where); !e.empty())
    throw std::invalid_argument("sun position: " + e);
  // Years 1000..3000: where libnova's Delta T and VSOP87's truncation stay accurate.
  if (!std::isfinite(utc_seconds) || utc_seconds < -30610224000.0 || utc_seconds > 32503680000.0)
    throw std::invalid_argument("sun position: time " + std::to_string(utc_seconds) +
                                " is not between the years 1000 and 3000");
  if (!(air.pressure_hpa > 0.0 && air.pressure_hpa < 1200.0) ||
      !(air.temperature_c > -90.0 && air.temperature_c < 70.0))
    throw std::invalid_argument(
        "sun position: pressure must be in (0, 1200) hPa and temperature "
        "in (-90, 70) C");
  const double jd = kUnixEpochJd + utc_seconds / 86400.0;
  // The sun's apparent place is a function of dynamical time (TT = UT + Delta T); the Earth's
  // rotation, in ln_get_hrz_from_equ, of universal time. The dissertation's SPA call took
  // Delta T as a constant (64.797 s); libnova models it by year.
  const double jde = jd + ln_get_dynamical_time_diff(jd) / 86400.0;
  // libnova's VSOP87 gives the sun's ecliptic longitude referred to the J2000 equinox, and its
  // ln_get_solar_equ_coords() does not precess it to the date: 0.05 deg off in 2003, 0.1 deg
  // in 1992 (Meeus ex. 25.b). So: precess (general precession in longitude, IAU 1976), then
  // nutation in longitude and aberration (-20.4898" / R) give the apparent longitude (Meeus
  // ch. 25), and the true obliquity (mean + nutation) the apparent right ascension and
  // declination. Against SPA's example: 0.0014 deg in elevation, 0.005 in azimuth.
  ln_helio_posn geometric{};
  ln_get_solar_geom_coords(jde, &geometric);
  const double t = (jde - 2451545.0) / 36525.0;  // Julian centuries of TT from J2000
  const double precession_deg = (5029.0966 * t + 1.11113 * t * t) / 3600.0;
  ln_nutation nutation{};
  ln_get_nutation(jde, &nutation);
  const double lambda =
      radians(geometric.L + precession_deg + nutation.longitude - 20.4898 / 3600.0 / geometric.R);
  const double beta = radians(geometric.B);
  const double epsilon = radians(nutation.ecliptic + nutation.obliquity);  // true obliquity
  ln_equ_posn equ{};
  equ.ra = degrees(std::atan2(
      std::sin(lambda) * std::cos(epsilon) - std::tan(beta) * std::sin(epsilon), std::cos(lambda)));
  if (equ.ra < 0.0) equ.ra += 360.0;
  equ.dec = degrees(std::asin(std::sin(beta) * std::cos(epsilon) +
                              std::cos(beta) * std::sin(epsilon) * std::sin(lambda)));
  ln_lnlat_posn observer{where.longitude_deg, where.latitude_deg};  // east positive, as ours
  ln_hrz_posn hrz{};
  ln_get_hrz_from_equ(&equ, &observer, jd, &hrz);
  SunPosition s;
  s.geometric_zenith_deg = 90.0 - hrz.alt;
  double elevation = hrz.alt;
  if (elevation >= kRefractionLimitDeg)
    elevation += ln_get_refraction_adj(elevation, air.pressure_hpa, air.temperature_c);
  s.zenith_deg = 90.0 - elevation;
  // libnova measures azimuth from south, westward; ours (SPA's) from north, eastward.
  s.azimuth_deg = std::fmod(hrz.az + 180.0, 360.0);
  if (s.azimuth_deg < 0.0) s.azimuth_deg += 360.0;
  return s;
}

glm::dvec3 sun_direction_world(const SunPosition& sun, double north_offset_deg) {
  // Dissertation eq. 5 (horizontal -> Cartesian), in our frame: east +X, up +Y, north -Z (its
  // "z is inverted" remark), with the azimuth measured from the orientation's north.
  const double a = radians(sun.azimuth_deg - north_offset_deg), e = radians(sun.elevation_deg());
  return {std::sin(a) * std::cos(e), std::sin(e), -std::cos(a) * std::cos(e)};
}

std::optional<BrightRegion> brightest_region(const EnvMap& measured) {
  const TexelTable& t = *texel_table(measured.layout);
  const std::span<const float> px = measured.image.storage();
  const auto lum_at = [&](std::size_t i) {
    const float* p = &px[std::size_t(t.index[i]) * 3];
    return double(luminance(p[0], p[1], p[2]));
  };
  double peak = 0, sum = 0, seen = 0;
  std::size_t peak_at = 0;
  for (std::size_t i = 0; i < t.size(); ++i) {
    const double l = lum_at(i);
    if (!(l > 0)) continue;  // never seen (or a negative, damaged texel)
    if (l > peak) peak = l, peak_at = i;
    sum += l * t.solid_angle[i], seen += t.solid_angle[i];
  }
  if (!(peak > 0)) return std::nullopt;
  // The light around the peak: texels over half its luminance within 15 degrees of it (a
  // second light elsewhere must not pull the centroid between the two).
  const glm::dvec3 peak_dir(t.x[peak_at], t.y[peak_at], t.z[peak_at]);
  const double near_cos = std::cos(radians(15.0));
  BrightRegion r;
  glm::dvec3 centroid(0.0);
  double region_sum = 0;
  for (std::size_t i = 0; i < t.size(); ++i) {
    const double l = lum_at(i);
    if (l < 0.5 * peak || glm::dot(glm::dvec3(t.x[i], t.y[i], t.z[i]), peak_dir) < near_cos)
      continue;
    centroid += l * t.solid_angle[i] * glm::dvec3(t.x[i], t.y[i], t.z[i]);
    region_sum += l * t.solid_angle[i];
    r.solid_angle_sr += t.solid_angle[i];
  }
  if (glm::length(centroid) > 0) r.direction = glm::normalize(centroid);
  r.contrast = (region_sum / r.solid_angle_sr) / (sum / seen);
  return r;
}

SunEstimate estimate_sun(const SunPosition& predicted, const std::optional<BrightRegion>& bright,
                         bool north_referenced, double north_offset_deg, const SunCheck& check) {
  SunEstimate e;
  e.north_offset_deg = north_offset_deg;
  e.direction = sun_direction_world(predicted, north_offset_deg);
  // Below the horizon once its upper limb has set (apparent elevation of the centre -0.27).
  if (predicted.elevation_deg() < -0.27) {
    e.state = SunState::BelowHorizon;
    return e;
  }
  e.state = SunState::Predicted;
  if (!bright || bright->solid_angle_sr > check.max_solid_angle_sr ||
      bright->contrast < check.min_contrast)
    return e;
  if (std::abs(elevation_deg(bright->direction) - predicted.elevation_deg()) >
      check.elevation_tolerance_deg)
    return e;
  const double measured_offset =
      azimuth_difference_deg(predicted.azimuth_deg, world_azimuth_deg(bright->direction));
  if (north_referenced && std::abs(azimuth_difference_deg(measured_offset, north_offset_deg)) >
                              check.azimuth_tolerance_deg)
    return e;
  e.state = SunState::Confirmed;
  e.north_offset_deg = measured_offset;
  e.direction = sun_direction_world(predicted, measured_offset);
  return e;
}

}  // namespace arlight::capture
