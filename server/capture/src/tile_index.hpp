// Internal: the capture's texels grouped by where they look, so a frame's projection visits
// only the part of the map its field of view can reach.
#pragma once

#include <cstdint>
#include <glm/vec3.hpp>
#include <memory>
#include <vector>

#include "arlight/common/projection.hpp"

namespace arlight::capture {

// The valid texels of a layout grouped in 16 x 16 tiles, each tile with a bounding cone, so a
// frame only visits the tiles its field of view can reach. It depends on the layout alone, so
// sessions share one (built once, ~50 ms and 5 MB for a 512^2 angle map).
struct TileIndex {
  struct Tile {
    std::size_t begin, end;  // range of entries in the arrays below
    glm::vec3 centre;        // unit
    float radius;            // radians: every texel direction of the tile is within it
  };
  std::vector<Tile> tiles;
  // One entry per valid texel, tile by tile: its unit direction (float), its index in the map
  // and its solid angle, so a frame reads all it needs in sequence instead of gathering from
  // the texel table.
  std::vector<float> dir_x, dir_y, dir_z;
  std::vector<std::uint32_t> texel;
  std::vector<double> solid_angle;
};

// The layout's index, built once per layout and shared (thread-safe).
std::shared_ptr<const TileIndex> tile_index_for(const EnvLayout& layout);

}  // namespace arlight::capture
