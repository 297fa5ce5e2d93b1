#include "arlight/net/map_assembly.hpp"

#include <cstring>
#include <string>

namespace arlight::client {

void MapSetAssembler::expect(const wire::RequestMaps& request) {
  requested_ = true;
  kind_ = request.kind;
  expected_ = request.shininess;
  levels_ = std::size_t(wire::ggx_level_count(request.size, request.levels));
  any_ = false;
}

void MapSetAssembler::expect_any() {
  requested_ = true;
  any_ = true;
}

// The codec has checked the tile's rectangle against its map's size at its level.
void MapSetAssembler::add_tile(const wire::MapTile& t) {
  if (!EnvLayout::guess_projection(int(t.map_width), int(t.map_height))) return;
  ReceivedMapSet& set = building_[t.map_set];
  set.id = t.map_set;
  set.kind = t.kind;
  const std::size_t index = t.map_index;
  if (set.maps.size() <= index) {
    const EnvLayout layout(t.projection, int(t.map_width), int(t.map_height));
    while (set.maps.size() <= index) set.maps.emplace_back(layout);
    set.shininess.resize(set.maps.size(), 0.0);
    set.roughness.resize(set.maps.size(), 0.0);
    set.texels_received.resize(set.maps.size(), 0);
  }
  set.shininess[index] = t.shininess;
  set.roughness[index] = t.roughness;
  if (t.level > 0) {
    set.preview_received = true;
    return;
  }
  EnvMap& map = set.maps[index];
  const std::uint64_t x = t.x, y = t.y, w = t.width, h = t.height;
  if (x + w > std::uint64_t(map.image.width()) || y + h > std::uint64_t(map.image.height()))
    return;  // another size than the set's first tile said
  std::string why;
  const auto px = wire::decode_half_rgb(t.data, std::size_t(w * h), t.coding, why);
  if (!px) return;
  for (std::uint64_t r = 0; r < h; ++r)
    std::memcpy(map.image.view().pixel(int(x), int(y + r)), px->data() + r * w * 3,
                sizeof(float) * 3 * w);
  set.texels_received[index] += std::size_t(w * h);
}

std::optional<ReceivedMapSet> MapSetAssembler::complete(const wire::MapSetComplete& c) {
  const auto it = building_.find(c.map_set);
  if (it == building_.end()) return std::nullopt;
  ReceivedMapSet set = std::move(it->second);
  building_.erase(building_.begin(), std::next(it));  // older sets are stale
  // Whole or not at all: a set whose first tiles went to an earlier connection of the session
  // (arlightd streams an in-flight set on to the one that resumed it) lacks maps or texels.
  if (!requested_ || (!any_ && set.kind != kind_) || set.maps.size() != c.maps)
    return std::nullopt;
  for (std::size_t i = 0; i < set.maps.size(); ++i)
    if (set.texels_received[i] !=
        std::size_t(set.maps[i].image.width()) * set.maps[i].image.height())
      return std::nullopt;
  if (set.kind == wire::MapKind::Phong) {
    if (!any_ && set.maps.size() != expected_.size()) return std::nullopt;
    for (std::size_t i = 0; i < set.maps.size(); ++i)
      if (!(set.shininess[i] > 0.0) || (!any_ && float(set.shininess[i]) != expected_[i]))
        return std::nullopt;
  } else {
    // A chain: cube maps halving their face, level 0 the mirror, roughness rising to 1 at most.
    if (!any_ && set.maps.size() != levels_) return std::nullopt;
    for (std::size_t i = 0; i < set.maps.size(); ++i) {
      const EnvLayout& l = set.maps[i].layout;
      if (l.projection() != Projection::Cube || l.height() != 6 * l.width() ||
          l.width() != set.maps[0].layout.width() >> i ||
          (i > 0 && !(set.roughness[i] > set.roughness[i - 1])) || set.roughness[i] > 1.0)
        return std::nullopt;
    }
    if (set.roughness[0] != 0.0) return std::nullopt;
  }
  set.complete = true;
  set.server_seconds = c.seconds;
  set.coverage = c.coverage;
  set.frames = c.frames;
  return set;
}

}  // namespace arlight::client
