#include "arlight/net/map_assembly.hpp"

#include <cstring>
#include <string>

namespace arlight::client {

void MapSetAssembler::expect(const wire::RequestMaps& request) {
  requested_ = true;
  kind_ = request.kind;
  expected_ = request.shininess;
  levels_ = std::size_t(wire::ggx_level_count(request.size, request.levels));
  lights_ = request.kind == wire::MapKind::Ggx ? request.specular_lights : 0;
  any_ = false;
  bases_.clear();  // sets of another request (the server starts the new one whole)
}

void MapSetAssembler::expect_any() {
  requested_ = true;
  any_ = true;
  bases_.clear();
}

// The codec has checked the tile's rectangle against its map's size at its level.
void MapSetAssembler::add_tile(const wire::MapTile& t) {
  if (!EnvLayout::guess_projection(int(t.map_width), int(t.map_height))) return;
  Building& b = building_[t.map_set];
  ReceivedMapSet& set = b.set;
  set.id = t.map_set;
  set.kind = t.kind;
  const std::size_t index = t.map_index;
  const EnvLayout layout(t.projection, int(t.map_width), int(t.map_height));
  if (set.maps.size() <= index) {
    while (set.maps.size() <= index) set.maps.emplace_back(layout);
    set.shininess.resize(set.maps.size(), 0.0);
    set.roughness.resize(set.maps.size(), 0.0);
    set.texels_received.resize(set.maps.size(), 0);
    b.received.resize(set.maps.size());
  }
  // A map made for a later map's first tile (in a set of changes, the maps before it may have
  // none) takes its own size from its own first tile.
  if (b.received[index].empty() && set.maps[index].layout != layout) set.maps[index] = EnvMap(layout);
  set.shininess[index] = t.shininess;
  set.roughness[index] = t.roughness;
  if (t.level > 0) {
    set.preview_received = true;
    return;
  }
  EnvMap& map = set.maps[index];
  const std::uint64_t x = t.x, y = t.y, w = t.width, h = t.height;
  const std::uint64_t width = std::uint64_t(map.image.width());
  if (x + w > width || y + h > std::uint64_t(map.image.height()))
    return;  // another size than the set's first tile said
  std::string why;
  const auto px = wire::decode_half_rgb(t.data, std::size_t(w * h), t.coding, why);
  if (!px) return;
  std::vector<bool>& received = b.received[index];
  received.resize(std::size_t(width) * std::size_t(map.image.height()), false);
  for (std::uint64_t r = 0; r < h; ++r) {
    std::memcpy(map.image.view().pixel(int(x), int(y + r)), px->data() + r * w * 3,
                sizeof(float) * 3 * w);
    for (std::uint64_t c = 0; c < w; ++c) {
      const std::size_t texel = std::size_t((y + r) * width + x + c);
      if (!received[texel]) ++set.texels_received[index];
      received[texel] = true;
    }
  }
  ++b.tiles;
}

std::optional<ReceivedMapSet> MapSetAssembler::apply_change(Building& b,
                                                            const wire::MapSetComplete& c) const {
  std::shared_ptr<const ReceivedMapSet> base;
  for (const auto& held : bases_)
    if (held->id == c.base_set) base = held;
  // A tile missing (the set began on an earlier connection) would show the base's stale one.
  if (!base || b.tiles != c.tiles || base->maps.size() != c.maps ||
      b.set.maps.size() > base->maps.size() || (b.tiles > 0 && b.set.kind != base->kind))
    return std::nullopt;
  ReceivedMapSet set = *base;
  set.id = c.map_set;
  set.base_set = c.base_set;
  set.preview_received = false;
  for (std::size_t i = 0; i < b.set.maps.size(); ++i) {
    const std::vector<bool>& received = b.received[i];
    if (received.empty()) continue;  // no tile of this map changed
    const Image& from = b.set.maps[i].image;
    Image& to = set.maps[i].image;
    if (b.set.maps[i].layout.projection() != set.maps[i].layout.projection() ||
        from.width() != to.width() || from.height() != to.height() ||
        float(b.set.shininess[i]) != float(set.shininess[i]) ||
        float(b.set.roughness[i]) != float(set.roughness[i]))
      return std::nullopt;
    for (int y = 0; y < to.height(); ++y)
      for (int x = 0; x < to.width(); ++x)
        if (received[std::size_t(y) * std::size_t(to.width()) + std::size_t(x)])
          std::memcpy(to.view().pixel(x, y), from.view().pixel(x, y), sizeof(float) * 3);
  }
  return set;
}

bool MapSetAssembler::as_expected(const ReceivedMapSet& set) const {
  if (!requested_ || (!any_ && set.kind != kind_)) return false;
  if (set.kind == wire::MapKind::Phong) {
    if (!any_ && set.maps.size() != expected_.size()) return false;
    for (std::size_t i = 0; i < set.maps.size(); ++i)
      if (!(set.shininess[i] > 0.0) || (!any_ && float(set.shininess[i]) != expected_[i]))
        return false;
    return true;
  }
  // A chain: cube maps halving their face, level 0 the mirror, roughness rising to 1 at most.
  if (!any_ && set.maps.size() != levels_) return false;
  for (std::size_t i = 0; i < set.maps.size(); ++i) {
    const EnvLayout& l = set.maps[i].layout;
    if (l.projection() != Projection::Cube || l.height() != 6 * l.width() ||
        l.width() != set.maps[0].layout.width() >> i ||
        (i > 0 && !(set.roughness[i] > set.roughness[i - 1])) || set.roughness[i] > 1.0)
      return false;
  }
  return !set.maps.empty() && set.roughness[0] == 0.0;
}

std::shared_ptr<const ReceivedMapSet> MapSetAssembler::complete(const wire::MapSetComplete& c) {
  const auto it = building_.find(c.map_set);
  // A change may carry no tile at all (nothing moved by more than the server's tolerance).
  if (it == building_.end() && c.base_set == 0) return nullptr;
  Building b = it == building_.end() ? Building{} : std::move(it->second);
  building_.erase(building_.begin(), it == building_.end() ? building_.upper_bound(c.map_set)
                                                           : std::next(it));  // older: stale
  std::optional<ReceivedMapSet> set;
  if (c.base_set != 0) {
    set = apply_change(b, c);
  } else {
    // Whole or not at all: a set whose first tiles went to an earlier connection of the session
    // (arlightd streams an in-flight set on to the one that resumed it) lacks maps or texels.
    bool whole = b.set.maps.size() == c.maps;
    for (std::size_t i = 0; whole && i < b.set.maps.size(); ++i)
      whole = b.set.texels_received[i] ==
              std::size_t(b.set.maps[i].image.width()) * b.set.maps[i].image.height();
    if (whole) set = std::move(b.set);
  }
  if (!set || !as_expected(*set)) return nullptr;
  // Lights beside a chain that was to hold the whole room would count them twice.
  if (!any_ && c.lights.size() > lights_) return nullptr;
  set->complete = true;
  set->server_seconds = c.seconds;
  set->coverage = c.coverage;
  set->frames = c.frames;
  set->lights = c.lights;
  auto done = std::make_shared<const ReceivedMapSet>(std::move(*set));
  bases_.push_back(done);
  while (bases_.size() > kBases) bases_.pop_front();
  return done;
}

}  // namespace arlight::client
