#include "map_set_delta.hpp"

#include <algorithm>
#include <cmath>

namespace arlight::daemon {

namespace {

// Half floats' smallest normal: below it a texel is black to every display.
constexpr float kBlack = 6.1e-5f;

bool same(const std::vector<float>& a, const std::vector<float>& b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i) {
    const float bound = MapSetDeltas::kTolerance * std::max(std::abs(a[i]), std::abs(b[i]));
    if (!(std::abs(a[i] - b[i]) <= std::max(bound, kBlack))) return false;  // NaN: changed
  }
  return true;
}

}  // namespace

void MapSetDeltas::clear() {
  std::lock_guard lock(mutex_);
  ++generation_;
  held_.clear();
}

std::uint32_t MapSetDeltas::begin(std::uint32_t id, std::uint64_t base) {
  std::lock_guard lock(mutex_);
  const auto it = held_.find(std::uint32_t(base));
  const std::uint32_t used = base != 0 && base <= id && it != held_.end() ? it->first : 0;
  building_ = Building{id, used, generation_, {}};
  return used;
}

std::uint32_t MapSetDeltas::shape(Shape maps) {
  std::lock_guard lock(mutex_);
  if (!building_) return 0;
  const auto base = held_.find(building_->base);
  if (base == held_.end() || base->second.shape != maps) building_->base = 0;
  building_->set.shape = std::move(maps);
  return building_->base;
}

bool MapSetDeltas::changed(const TileKey& key, std::shared_ptr<const std::vector<float>> texels) {
  std::lock_guard lock(mutex_);
  if (!building_) return true;
  if (building_->base != 0) {
    const auto base = held_.find(building_->base);
    if (base != held_.end()) {
      const auto tile = base->second.tiles.find(key);
      if (tile != base->second.tiles.end() && same(*tile->second, *texels)) {
        building_->set.tiles[key] = tile->second;  // the client keeps the base's
        return false;
      }
    }
  }
  building_->set.tiles[key] = std::move(texels);
  return true;
}

void MapSetDeltas::complete() {
  std::lock_guard lock(mutex_);
  if (!building_) return;
  Building b = std::move(*building_);
  building_.reset();
  if (b.generation != generation_) return;
  held_[b.id] = std::move(b.set);
  // A later set's base is the connection's newest begun set when it starts: this one's base
  // (still being written), the set before this one (queued when this one's base was read: it
  // may begin before this one replaces it), or this one. The rest never begin: on a slow link
  // the sets computed while one is written replace each other unsent, and must not push out
  // the one being written.
  const auto self = held_.find(b.id);
  const std::uint32_t before = self == held_.begin() ? 0 : std::prev(self)->first;
  std::erase_if(held_, [&](const auto& entry) {
    const std::uint32_t id = entry.first;
    return id != b.id && id != before && (b.base == 0 || id != b.base);
  });
}

std::size_t MapSetDeltas::held() const {
  std::lock_guard lock(mutex_);
  return held_.size();
}

}  // namespace arlight::daemon
