// The input of the direct-integration methods: weighted radiance samples on the sphere, grouped
// in cells of a cube grid so that a query can skip every cell its lobe cannot reach.
#pragma once

#include <algorithm>
#include <cstdint>
#include <glm/vec3.hpp>
#include <vector>

#include "arlight/common/projection.hpp"

namespace arlight::lighting::detail {

// Largest number of points in one cell (the kernels keep a cell's temporaries on the stack).
constexpr std::uint32_t kMaxCellPoints = 256;
// Cells are padded with zero-weight points to a multiple of this (one AVX-512 register of
// floats, two of doubles).
constexpr std::uint32_t kCellAlign = 16;

struct PointCells {
  // Structure of arrays; the points of one cell are contiguous.
  std::vector<double> x, y, z;     // unit direction
  std::vector<double> w;           // solid angle (sr)
  std::vector<double> lr, lg, lb;  // radiance x solid angle
  // Prefiltered points only (empty otherwise): the first moments of each channel's radiance
  // deviation about the point, sum (L_c - mean L_c) w (w_i - dir), as x, y, z arrays for
  // c = r, g, b. They carry the first-order term of the lobe's variation over the cell.
  std::vector<double> moment[9];
  bool has_moments() const { return !moment[0].empty() || !fmoment[0].empty(); }

  // Single-precision copies of every array above, for the float kernel (accumulate_single_f32);
  // empty until make_float_copy().
  std::vector<float> fx, fy, fz, fw, flr, flg, flb, fmoment[9];
  bool has_float() const { return !fx.empty(); }
  void make_float_copy();

  // Per cell, the sums over its points of (lr, lg, lb, w) x direction (12 values): what the
  // clamped cosine lobe (s = 1) adds from a cell wholly above a direction's horizon, where it
  // is linear. Empty until make_cell_sums().
  std::vector<double> cell_sums;
  void make_cell_sums();

  struct Cell {
    std::uint32_t begin, end;
    glm::dvec3 centre;    // unit
    double cos_r, sin_r;  // every point lies within angle r of the centre
  };
  std::vector<Cell> cells;

  // Runs of up to 16 consecutive cells (a 4x4 patch of the grid) with their own bounding
  // cone, so that a narrow lobe skips most of the sphere with one test per block.
  struct Block {
    std::uint32_t first_cell, last_cell;  // [first, last)
    glm::dvec3 centre;
    double cos_r, sin_r;
  };
  std::vector<Block> blocks;

  double spacing = 0.0;  // typical angular distance between neighbouring points (rad)

  std::size_t size() const { return std::max(x.size(), fx.size()); }

  // Largest cosine between `d` and any point within the cone (centre, r), as an upper bound
  // padded for rounding.
  template <class Cone>
  static double max_cos(const Cone& cone, glm::dvec3 d) {
    return cone_max_cos(cone.centre, cone.cos_r, cone.sin_r, d);
  }
  static double cone_max_cos(glm::dvec3 centre, double cos_r, double sin_r, glm::dvec3 d);

  // Calls fn(cell) for every cell holding a point whose cosine with `d` exceeds min_cos >= 0.
  template <class Fn>
  void for_cells_within(glm::dvec3 d, double min_cos, Fn&& fn) const {
    for (const Block& b : blocks) {
      if (max_cos(b, d) <= min_cos) continue;
      for (std::uint32_t c = b.first_cell; c < b.last_cell; ++c)
        if (max_cos(cells[c], d) > min_cos) fn(cells[c]);
    }
  }
};

// Every valid texel of `env` as one point (the full-resolution input), ~points_per_cell points
// to a cell: large cells suit whole-hemisphere sums, small ones narrow windows.
// With skip_black, texels with no radiance are left out (for sparse maps).
PointCells points_from_texels(const EnvMap& env, int points_per_cell = 64, bool skip_black = false);

// The texels of `env` summed into the cells of a cube grid with `face` cells per face edge: each
// non-empty grid cell becomes one point at the solid-angle-weighted mean direction of its texels,
// carrying their summed solid angle and radiance and the radiance's first moments. This is a
// prefiltered, lower resolution copy of the input that keeps its total power exactly.
PointCells points_aggregated(const EnvMap& env, int face, int points_per_cell = 64);

// Copies into `out` (replacing its contents) every cell of `src` that holds a point whose cosine
// with `centre` exceeds min_cos: the candidates of a batch of nearby directions, contiguous.
void gather_cells(const PointCells& src, glm::dvec3 centre, double min_cos, PointCells& out);

}  // namespace arlight::lighting::detail
