// Comma-separated lists of numbers from command lines ("1,10,80", "0.8,0.2,80").
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

}  // namespace arlight
