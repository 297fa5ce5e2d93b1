#include "tile_index.hpp"

#include <algorithm>
#include <cmath>
#include <glm/geometric.hpp>
#include <map>
#include <mutex>
#include <tuple>

namespace arlight::capture {

namespace {

std::shared_ptr<const TileIndex> build_tile_index(const TexelTable& table) {
  constexpr int kTile = 16;
  auto index = std::make_shared<TileIndex>();
  const int w = table.layout.width(), h = table.layout.height();
  const int tw = (w + kTile - 1) / kTile, th = (h + kTile - 1) / kTile;
  std::vector<std::vector<std::uint32_t>> members(std::size_t(tw) * th);
  for (std::size_t i = 0; i < table.size(); ++i) {
    const std::uint32_t t = table.index[i];
    const int x = int(t % std::uint32_t(w)), y = int(t / std::uint32_t(w));
    members[std::size_t(y / kTile) * tw + x / kTile].push_back(std::uint32_t(i));
  }
  for (const auto& m : members) {
    if (m.empty()) continue;
    glm::dvec3 sum(0.0);
    for (std::uint32_t i : m) sum += glm::dvec3(table.x[i], table.y[i], table.z[i]);
    const glm::dvec3 c = glm::length(sum) > 1e-9 ? glm::normalize(sum) : glm::dvec3(0, 0, 1);
    double radius = 0.0;
    for (std::uint32_t i : m)
      radius = std::max(
          radius, std::acos(std::clamp(glm::dot(c, glm::dvec3(table.x[i], table.y[i], table.z[i])),
                                       -1.0, 1.0)));
    index->tiles.push_back(
        {index->texel.size(), index->texel.size() + m.size(), glm::vec3(c), float(radius + 1e-3)});
    for (std::uint32_t i : m) {
      index->dir_x.push_back(float(table.x[i]));
      index->dir_y.push_back(float(table.y[i]));
      index->dir_z.push_back(float(table.z[i]));
      index->texel.push_back(table.index[i]);
      index->solid_angle.push_back(table.solid_angle[i]);
    }
  }
  return index;
}

}  // namespace

std::shared_ptr<const TileIndex> tile_index_for(const EnvLayout& layout) {
  static std::mutex mutex;
  static std::map<std::tuple<int, int, int>, std::shared_ptr<const TileIndex>> cache;
  std::lock_guard lock(mutex);
  auto& slot = cache[{int(layout.projection()), layout.width(), layout.height()}];
  if (!slot) slot = build_tile_index(*texel_table(layout));
  return slot;
}

}  // namespace arlight::capture
