#include "points.hpp"

#include <algorithm>
#include <cmath>
#include <glm/geometric.hpp>
#include <numbers>
#include <numeric>

namespace arlight::lighting::detail {

namespace {

std::uint32_t morton(std::uint32_t x, std::uint32_t y) {
  std::uint32_t m = 0;
  for (int b = 0; b < 14; ++b) m |= ((x >> b) & 1u) << (2 * b) | ((y >> b) & 1u) << (2 * b + 1);
  return m;
}

struct RawPoint {
  glm::dvec3 dir;
  double w;
  glm::dvec3 lw;
  glm::dvec3 moment[3] = {glm::dvec3(0.0), glm::dvec3(0.0), glm::dvec3(0.0)};
};

// Sorts points into the cells of a cube grid (~points_per_cell a cell), splits cells above
// kMaxCellPoints, and measures each cell's bounding cone.
PointCells bucket(std::vector<RawPoint> pts, int points_per_cell, bool moments) {
  PointCells out;
  const std::size_t n = pts.size();
  out.spacing = n ? std::sqrt(4.0 * std::numbers::pi / double(n)) : 0.0;
  const int grid = std::max(1, int(std::lround(std::sqrt(double(n) / (6.0 * points_per_cell)))));
  const EnvLayout cells_layout = EnvLayout::for_size(Projection::Cube, grid);
  // Cells in Morton order within each face, so that 16 consecutive cells form a 4x4 patch;
  // points sorted by cell with a counting sort (keys are dense: face x 4^bits).
  int bits = 0;
  while ((1 << bits) < grid) ++bits;
  const std::uint32_t per_face = 1u << (2 * bits);
  std::vector<std::uint32_t> key(n), count(6 * std::size_t(per_face) + 1, 0);
  for (std::size_t i = 0; i < n; ++i) {
    const glm::ivec2 t = cells_layout.dir_to_texel(pts[i].dir);
    const int face = t.y / grid;
    key[i] = std::uint32_t(face) * per_face +
             morton(std::uint32_t(t.x), std::uint32_t(t.y - face * grid));
    ++count[key[i] + 1];
  }
  for (std::size_t k = 1; k < count.size(); ++k) count[k] += count[k - 1];
  std::vector<std::uint32_t> order(n);
  for (std::size_t i = 0; i < n; ++i) order[count[key[i]]++] = std::uint32_t(i);
  for (auto* v : {&out.x, &out.y, &out.z, &out.w, &out.lr, &out.lg, &out.lb}) v->reserve(n + n / 4);
  auto push = [&](const RawPoint& p) {
    out.x.push_back(p.dir.x), out.y.push_back(p.dir.y), out.z.push_back(p.dir.z);
    out.w.push_back(p.w);
    out.lr.push_back(p.lw.x), out.lg.push_back(p.lw.y), out.lb.push_back(p.lw.z);
    if (moments)
      for (int c = 0; c < 3; ++c)
        for (int a = 0; a < 3; ++a) out.moment[3 * c + a].push_back(p.moment[c][a]);
  };
  // Each cell's points, then zero points (no direction, no weight) up to a multiple of
  // kCellAlign, so the kernels run whole SIMD groups.
  auto add_cell = [&](std::size_t first, std::size_t last) {
    const auto begin = std::uint32_t(out.x.size());
    glm::dvec3 c(0.0);
    for (std::size_t i = first; i < last; ++i) {
      push(pts[order[i]]);
      c += pts[order[i]].dir;
    }
    c = glm::length(c) > 0 ? glm::normalize(c) : pts[order[first]].dir;
    double cos_r = 1.0;
    for (std::size_t i = first; i < last; ++i)
      cos_r = std::min(cos_r, glm::dot(c, pts[order[i]].dir));
    cos_r = std::clamp(cos_r, -1.0, 1.0);
    while (out.x.size() % kCellAlign) push({glm::dvec3(0.0), 0.0, glm::dvec3(0.0)});
    out.cells.push_back({begin, std::uint32_t(out.x.size()), c, cos_r,
                         std::sqrt(std::max(0.0, 1.0 - cos_r * cos_r))});
  };
  for (std::size_t begin = 0; begin < n;) {
    std::size_t end = begin;
    while (end < n && key[order[end]] == key[order[begin]]) ++end;
    for (std::size_t b = begin; b < end; b += kMaxCellPoints)
      add_cell(b, std::min(end, b + kMaxCellPoints));
    begin = end;
  }
  constexpr std::uint32_t kBlock = 16;
  for (std::uint32_t first = 0; first < out.cells.size(); first += kBlock) {
    const std::uint32_t last =
        std::min<std::uint32_t>(std::uint32_t(out.cells.size()), first + kBlock);
    glm::dvec3 c(0.0);
    for (std::uint32_t i = first; i < last; ++i) c += out.cells[i].centre;
    c = glm::length(c) > 0 ? glm::normalize(c) : out.cells[first].centre;
    double r = 0.0;
    for (std::uint32_t i = first; i < last; ++i) {
      const auto& cell = out.cells[i];
      r = std::max(
          r, std::acos(std::clamp(glm::dot(c, cell.centre), -1.0, 1.0)) + std::acos(cell.cos_r));
    }
    r = std::min(r, std::numbers::pi);
    out.blocks.push_back({first, last, c, std::cos(r), std::sin(r)});
  }
  return out;
}

}  // namespace

double PointCells::cone_max_cos(glm::dvec3 centre, double cos_r, double sin_r, glm::dvec3 d) {
  const double cos_a = glm::dot(d, centre);
  if (cos_a >= cos_r) return 1.0;
  const double sin_a = std::sqrt(std::max(0.0, 1.0 - cos_a * cos_a));
  // cos(a - r), padded so that rounding never culls a point that contributes.
  return std::min(1.0, cos_a * cos_r + sin_a * sin_r + 1e-9);
}

PointCells points_from_texels(const EnvMap& env, int points_per_cell, bool skip_black) {
  const auto table = texel_table(env.layout);
  std::vector<RawPoint> pts;
  pts.reserve(table->size());
  const float* px = env.image.data();
  for (std::size_t i = 0; i < table->size(); ++i) {
    const float* p = px + 3 * std::size_t(table->index[i]);
    if (skip_black && p[0] <= 0.0f && p[1] <= 0.0f && p[2] <= 0.0f) continue;
    const double w = table->solid_angle[i];
    pts.push_back({{table->x[i], table->y[i], table->z[i]}, w, glm::dvec3(p[0], p[1], p[2]) * w});
  }
  return bucket(std::move(pts), points_per_cell, false);
}

PointCells points_aggregated(const EnvMap& env, int face, int points_per_cell) {
  const auto table = texel_table(env.layout);
  const EnvLayout grid = EnvLayout::for_size(Projection::Cube, face);
  // Two passes: the cells' centroids and sums, then the moments about the centroids.
  struct Sum {
    glm::dvec3 dir{0.0};
    double w = 0.0;
    glm::dvec3 lw{0.0};
    glm::dvec3 moment[3] = {glm::dvec3(0.0), glm::dvec3(0.0), glm::dvec3(0.0)};
  };
  std::vector<Sum> sums(grid.texel_count());
  std::vector<std::uint32_t> cell_of(table->size());
  const float* px = env.image.data();
  for (std::size_t i = 0; i < table->size(); ++i) {
    const glm::dvec3 d(table->x[i], table->y[i], table->z[i]);
    const glm::ivec2 t = grid.dir_to_texel(d);
    cell_of[i] = std::uint32_t(t.y) * std::uint32_t(face) + std::uint32_t(t.x);
    Sum& s = sums[cell_of[i]];
    const double w = table->solid_angle[i];
    const float* p = px + 3 * std::size_t(table->index[i]);
    s.dir += w * d;
    s.w += w;
    s.lw += w * glm::dvec3(p[0], p[1], p[2]);
  }
  for (Sum& s : sums)
    if (s.w > 0.0 && glm::length(s.dir) > 0.0) s.dir = glm::normalize(s.dir);
  for (std::size_t i = 0; i < table->size(); ++i) {
    Sum& s = sums[cell_of[i]];
    const glm::dvec3 d(table->x[i], table->y[i], table->z[i]);
    const double w = table->solid_angle[i];
    const float* p = px + 3 * std::size_t(table->index[i]);
    for (int c = 0; c < 3; ++c) s.moment[c] += (p[c] - s.lw[c] / s.w) * w * (d - s.dir);
  }
  std::vector<RawPoint> pts;
  pts.reserve(sums.size());
  for (const Sum& s : sums)
    if (s.w > 0.0 && glm::length(s.dir) > 0.0)
      pts.push_back({s.dir, s.w, s.lw, {s.moment[0], s.moment[1], s.moment[2]}});
  return bucket(std::move(pts), points_per_cell, true);
}

void PointCells::make_float_copy() {
  auto conv = [](const std::vector<double>& from, std::vector<float>& to) {
    to.assign(from.begin(), from.end());
  };
  conv(x, fx), conv(y, fy), conv(z, fz), conv(w, fw), conv(lr, flr), conv(lg, flg), conv(lb, flb);
  for (int m = 0; m < 9; ++m) conv(moment[m], fmoment[m]);
}

void PointCells::make_cell_sums() {
  cell_sums.assign(12 * cells.size(), 0.0);
  for (std::size_t c = 0; c < cells.size(); ++c) {
    double* m = &cell_sums[12 * c];
    for (std::uint32_t i = cells[c].begin; i < cells[c].end; ++i) {
      const double v[4] = {lr[i], lg[i], lb[i], w[i]};
      for (int k = 0; k < 4; ++k)
        m[3 * k] += v[k] * x[i], m[3 * k + 1] += v[k] * y[i], m[3 * k + 2] += v[k] * z[i];
    }
  }
}

void gather_cells(const PointCells& src, glm::dvec3 centre, double min_cos, PointCells& out) {
  for (auto* v : {&out.x, &out.y, &out.z, &out.w, &out.lr, &out.lg, &out.lb}) v->clear();
  for (auto& m : out.moment) m.clear();
  for (auto* v : {&out.fx, &out.fy, &out.fz, &out.fw, &out.flr, &out.flg, &out.flb}) v->clear();
  for (auto& m : out.fmoment) m.clear();
  const bool floats = src.has_float();
  out.cells.clear();
  out.blocks.clear();
  out.spacing = src.spacing;
  src.for_cells_within(centre, min_cos, [&](const PointCells::Cell& cell) {
    const auto begin = std::uint32_t(out.size());
    auto copy = [&](const std::vector<double>& from, std::vector<double>& to) {
      to.insert(to.end(), from.begin() + cell.begin, from.begin() + cell.end);
    };
    copy(src.x, out.x), copy(src.y, out.y), copy(src.z, out.z), copy(src.w, out.w);
    copy(src.lr, out.lr), copy(src.lg, out.lg), copy(src.lb, out.lb);
    if (src.has_moments())
      for (int m = 0; m < 9; ++m) copy(src.moment[m], out.moment[m]);
    if (floats) {
      auto copyf = [&](const std::vector<float>& from, std::vector<float>& to) {
        to.insert(to.end(), from.begin() + cell.begin, from.begin() + cell.end);
      };
      copyf(src.fx, out.fx), copyf(src.fy, out.fy), copyf(src.fz, out.fz), copyf(src.fw, out.fw);
      copyf(src.flr, out.flr), copyf(src.flg, out.flg), copyf(src.flb, out.flb);
      if (src.has_moments())
        for (int m = 0; m < 9; ++m) copyf(src.fmoment[m], out.fmoment[m]);
    }
    PointCells::Cell c = cell;
    c.begin = begin, c.end = std::uint32_t(out.size());
    out.cells.push_back(c);
  });
}

}  // namespace arlight::lighting::detail
