// Numbers from command lines: comma-separated lists ("1,10,80", "0.8,0.2,80"), image sizes
// ("640x480"), places ("51.45,-2.59") and UTC times ("2026-06-21T12:00:00Z").
#pragma once

#include <charconv>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <string>
#include <string_view>
#include <vector>

#include "arlight/common/error.hpp"
#include "arlight/common/geo.hpp"

namespace arlight {

// The numbers of `text` ("" gives none). InputError "<what>: '<item>' is not a number" for an
// empty, partial or non-finite item, so the user sees which flag and which item.
inline std::vector<double> parse_number_list(std::string_view text, std::string_view what) {
  std::vector<double> out;
  if (text.empty()) return out;
  for (std::size_t start = 0;;) {
    const std::size_t comma = text.find(',', start);
    const std::string_view item = text.substr(
        start, comma == std::string_view::npos ? std::string_view::npos : comma - start);
    double v = 0;
    const auto [end, ec] = std::from_chars(item.data(), item.data() + item.size(), v);
    if (item.empty() || ec != std::errc() || end != item.data() + item.size() || !std::isfinite(v))
      throw InputError(std::string(what) + ": '" + std::string(item) + "' is not a number");
    out.push_back(v);
    if (comma == std::string_view::npos) return out;
    start = comma + 1;
  }
}

struct ImageSize {
  int width = 0, height = 0;
};

// "WIDTHxHEIGHT" (8..16384 each). InputError naming `what` and the text otherwise.
inline ImageSize parse_image_size(std::string_view text, std::string_view what) {
  const std::size_t x = text.find_first_of("xX");
  ImageSize s;
  const auto number = [&](std::string_view part, int& v) {
    const auto [end, ec] = std::from_chars(part.data(), part.data() + part.size(), v);
    return !part.empty() && ec == std::errc() && end == part.data() + part.size();
  };
  if (x == std::string_view::npos || !number(text.substr(0, x), s.width) ||
      !number(text.substr(x + 1), s.height))
    throw InputError(std::string(what) + " '" + std::string(text) +
                     "': expected WIDTHxHEIGHT, e.g. 640x480");
  if (s.width < 8 || s.height < 8 || s.width > 16384 || s.height > 16384)
    throw InputError(std::string(what) + " '" + std::string(text) +
                     "': width and height must be 8..16384");
  return s;
}

// "LAT,LON[,ALT]" (degrees, degrees, metres). InputError naming `what` otherwise.
inline GeoLocation parse_geo_location(std::string_view text, std::string_view what) {
  const std::vector<double> v = parse_number_list(text, what);
  if (v.size() != 2 && v.size() != 3)
    throw InputError(std::string(what) + " '" + std::string(text) +
                     "': expected LAT,LON or LAT,LON,ALT (degrees, degrees, metres)");
  const GeoLocation g{v[0], v[1], v.size() == 3 ? v[2] : 0.0};
  if (const std::string e = geo_location_error(g); !e.empty())
    throw InputError(std::string(what) + " '" + std::string(text) + "': " + e);
  return g;
}

// "YYYY-MM-DDTHH:MM[:SS]" in UTC (a trailing "Z" allowed) as Unix seconds. InputError naming
// `what` for anything else or an impossible date.
inline double parse_utc_time(std::string_view text, std::string_view what) {
  int y = 0, mo = 0, d = 0, h = 0, mi = 0, n = 0;
  double sec = 0;
  std::string t(text);
  if (!t.empty() && (t.back() == 'Z' || t.back() == 'z')) t.pop_back();
  const bool with_seconds =
      std::sscanf(t.c_str(), "%d-%d-%dT%d:%d:%lf%n", &y, &mo, &d, &h, &mi, &sec, &n) == 6;
  if (!with_seconds) sec = 0, n = 0;
  const bool ok =
      (with_seconds || std::sscanf(t.c_str(), "%d-%d-%dT%d:%d%n", &y, &mo, &d, &h, &mi, &n) == 5) &&
      n == int(t.size());
  const std::chrono::year_month_day date{std::chrono::year{y}, std::chrono::month(unsigned(mo)),
                                         std::chrono::day(unsigned(d))};
  if (!ok || !date.ok() || y < 1000 || y > 3000 || h < 0 || h > 23 || mi < 0 || mi > 59 ||
      !(sec >= 0 && sec < 61))
    throw InputError(std::string(what) + " '" + std::string(text) +
                     "': expected a UTC time YYYY-MM-DDTHH:MM[:SS][Z], e.g. 2026-06-21T12:00:00Z");
  const auto days = std::chrono::sys_days(date).time_since_epoch().count();
  return double(days) * 86400.0 + h * 3600.0 + mi * 60.0 + sec;
}

}  // namespace arlight
