// Numbers from command lines: comma-separated lists ("1,10,80", "0.8,0.2,80") and image sizes
// ("640x480").
#pragma once

#include <charconv>
#include <cmath>
#include <string>
#include <string_view>
#include <vector>

#include "arlight/error.hpp"

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

}  // namespace arlight
