// Method `auto`: every map by direct lobe integration (Alg. 4.1, so exact in the limit), made
// cheap by matching both sides of the integral to the lobe's width sigma(s):
//
// - Input: the coarsest prefiltered copy of the input whose points are at most sigma /
//   input_per_sigma apart (points_aggregated: cube-grid cells keep the exact total power and
//   their weighted mean direction), or the input texels themselves when none is coarse enough.
//   The number of points under a lobe is then ~constant (a few hundred) for every s.
// - Window: only points where cos^s exceeds the bounded method's threshold (at most 0.1 % of
//   eps lost, derivation in direct.cpp), found through the cell hierarchy.
// - Output: when the lobe spans several output texels, the map is band-limited accordingly, so
//   it is integrated on a cube grid sigma / output_per_sigma apart (with a 2-texel border so no
//   lookup crosses a face) and read at each output texel by bicubic (Catmull-Rom)
//   interpolation on that face. Otherwise each output texel is integrated directly.
//
// Cost per map ~ (#grid points) x (#points under the lobe) is then nearly independent of s:
// the irradiance map costs as little as the sharpest reflection map. Measured errors and times
// of the default tuning: see bench/RESULTS.md and the constants in lighting.hpp.
#include <tbb/parallel_for.h>

#include <chrono>
#include <cmath>
#include <glm/geometric.hpp>
#include <map>
#include <memory>
#include <mutex>
#include <numbers>
#include <sstream>

#include "direct.hpp"
#include "job.hpp"
#include "kernels.hpp"

namespace arlight::lighting::detail {

namespace {

// Directions integrated together (one gather of nearby points): kBlock x kBlock texels.
constexpr int kBlock = 8;

// Typical spacing (rad) of a cube grid with `face` cells per edge.
double cube_spacing(int face) { return std::sqrt(4.0 * std::numbers::pi / (6.0 * face * face)); }

// The input at several resolutions, built on demand.
class InputLevels {
 public:
  explicit InputLevels(const EnvMap& input) : input_(input) {}

  const PointCells& full() {
    std::lock_guard lock(mutex_);
    if (!full_) full_ = std::make_unique<PointCells>(points_from_texels(input_));
    return *full_;
  }
  double full_spacing() const {
    return std::sqrt(4.0 * std::numbers::pi / double(texel_table(input_.layout)->size()));
  }
  const PointCells& aggregated(int face) {
    std::lock_guard lock(mutex_);
    auto& slot = levels_[face];
    if (!slot) slot = std::make_unique<PointCells>(points_aggregated(input_, face));
    return *slot;
  }

 private:
  const EnvMap& input_;
  std::mutex mutex_;
  std::unique_ptr<PointCells> full_;
  std::map<int, std::unique_ptr<PointCells>> levels_;
};

// Values on a cube grid with a border of kBorder texels beyond each face edge, read back by
// Catmull-Rom interpolation within the face a direction falls on.
class CubeGrid {
 public:
  static constexpr int kBorder = 2;

  explicit CubeGrid(int face) : face_(face), side_(face + 2 * kBorder) {
    const EnvLayout cube = EnvLayout::for_size(Projection::Cube, 1);
    for (int f = 0; f < 6; ++f) {
      const double v = (f + 0.5) / 6.0;
      normal_[f] = cube.uv_to_dir({0.5, v});
      // Points halfway to the right and bottom edges: a = 0.5, b = 0.5 in face coordinates.
      const glm::dvec3 right = cube.uv_to_dir({0.75, v});
      const glm::dvec3 down = cube.uv_to_dir({0.5, (f + 0.75) / 6.0});
      right_[f] = 2.0 * (right / glm::dot(right, normal_[f]) - normal_[f]);
      down_[f] = 2.0 * (down / glm::dot(down, normal_[f]) - normal_[f]);
    }
    values_.assign(6 * std::size_t(side_) * std::size_t(side_) * 3, 0.0f);
  }

  int side() const { return side_; }
  std::size_t point_count() const { return 6 * std::size_t(side_) * std::size_t(side_); }

  // Direction of grid point (i, j) of face f, i and j from 0 to side-1 (border included).
  glm::dvec3 dir(int f, int i, int j) const {
    const double a = 2.0 * (i - kBorder + 0.5) / face_ - 1.0;
    const double b = 2.0 * (j - kBorder + 0.5) / face_ - 1.0;
    return glm::normalize(normal_[f] + a * right_[f] + b * down_[f]);
  }
  float* value(int f, int i, int j) {
    return values_.data() + 3 * ((std::size_t(f) * side_ + std::size_t(j)) * side_ + std::size_t(i));
  }

  glm::vec3 sample(glm::dvec3 d) const {
    const int f = EnvLayout::cube_face_of_direction(d);
    const glm::dvec3 p = d / glm::dot(d, normal_[f]);
    const double x = (glm::dot(p, right_[f]) + 1.0) * 0.5 * face_ - 0.5 + kBorder;
    const double y = (glm::dot(p, down_[f]) + 1.0) * 0.5 * face_ - 0.5 + kBorder;
    const int x0 = std::clamp(int(std::floor(x)), 1, side_ - 3);
    const int y0 = std::clamp(int(std::floor(y)), 1, side_ - 3);
    double wx[4], wy[4];
    catmull_rom(x - x0, wx);
    catmull_rom(y - y0, wy);
    glm::dvec3 sum(0.0);
    const float* base = values_.data() + 3 * std::size_t(f) * side_ * side_;
    for (int j = 0; j < 4; ++j) {
      glm::dvec3 row(0.0);
      for (int i = 0; i < 4; ++i) {
        const float* v = base + 3 * (std::size_t(y0 - 1 + j) * side_ + std::size_t(x0 - 1 + i));
        row += wx[i] * glm::dvec3(v[0], v[1], v[2]);
      }
      sum += wy[j] * row;
    }
    // Catmull-Rom can overshoot slightly below 0 next to a sharp highlight; radiance cannot.
    return glm::vec3(glm::max(sum, glm::dvec3(0.0)));
  }

 private:
  static void catmull_rom(double t, double* w) {
    const double t2 = t * t, t3 = t2 * t;
    w[0] = 0.5 * (-t3 + 2 * t2 - t);
    w[1] = 0.5 * (3 * t3 - 5 * t2 + 2);
    w[2] = 0.5 * (-3 * t3 + 4 * t2 + t);
    w[3] = 0.5 * (t3 - t2);
  }

  int face_, side_;
  glm::dvec3 normal_[6], right_[6], down_[6];
  std::vector<float> values_;
};

struct Plan {
  double sigma;
  int input_face;  // 0: the input texels themselves
  double input_spacing;
  int grid_face;  // 0: integrate at every output texel
};

Plan make_plan(double s, const AutoTuning& tuning, double full_spacing, std::size_t out_texels) {
  Plan p;
  p.sigma = lobe_sigma(s);
  // Coarsest power-of-two cube grid that still has input_per_sigma points per sigma and is
  // coarser than the input itself.
  p.input_face = 0;
  p.input_spacing = full_spacing;
  for (int face = 2; face <= 4096; face *= 2) {
    const double h = cube_spacing(face);
    if (h <= full_spacing * 1.2) break;
    if (p.sigma / h >= tuning.input_per_sigma) {
      p.input_face = face;
      p.input_spacing = h;
      break;
    }
  }
  const int grid = std::max(4, int(std::ceil(std::sqrt(4.0 * std::numbers::pi / 6.0) *
                                             tuning.output_per_sigma / p.sigma)));
  const std::size_t grid_points = 6 * std::size_t(grid + 2 * CubeGrid::kBorder) *
                                  std::size_t(grid + 2 * CubeGrid::kBorder);
  p.grid_face = grid_points * 2 < out_texels ? grid : 0;
  return p;
}

std::string describe(const Plan& p, double seconds) {
  std::ostringstream o;
  o.precision(3);
  o << "auto: sigma " << p.sigma * 180.0 / std::numbers::pi << " deg; input ";
  if (p.input_face) o << "prefiltered to a " << p.input_face << "^2 x 6 cube grid";
  else o << "texels";
  o << "; output ";
  if (p.grid_face) o << "from a " << p.grid_face << "^2 x 6 cube grid (bicubic)";
  else o << "texels integrated directly";
  o << "; " << seconds << " s";
  return o.str();
}

}  // namespace

MapSet run_auto(const Job& job) {
  InputLevels levels(job.input);
  const std::size_t out_texels = texel_table(job.output.layout())->size();
  const int count = int(job.shininess.size());
  std::vector<EnvMap> maps = blank_maps(job);
  MapSet result;
  result.seconds.assign(std::size_t(count), 0.0);
  result.plans.assign(std::size_t(count), "");
  // Cheapest (widest lobe) first, so a consumer gets usable maps early.
  for (int k : ascending_order(job.shininess)) {
    const auto t0 = std::chrono::steady_clock::now();
    const double s = job.shininess[std::size_t(k)];
    const Plan plan = make_plan(s, job.spec.tuning, levels.full_spacing(), out_texels);
    const PointCells& pts = plan.input_face ? levels.aggregated(plan.input_face) : levels.full();
    const double one[] = {s};
    const PowerChain chain(one);
    const double min_cos = bounded_cos_threshold(s);
    // Integrates up to kBlock x kBlock nearby directions; values are written to out[i].
    auto integrate_block = [&](std::vector<glm::dvec3>& dirs, auto&& write) {
      BatchIntegrator batch(pts, chain, min_cos);
      std::vector<double> acc(4 * dirs.size());
      batch.run(dirs, acc.data());
      for (std::size_t i = 0; i < dirs.size(); ++i) {
        const double* a = acc.data() + 4 * i;
        write(i, a[3] > 0.0 ? glm::vec3(a[0] / a[3], a[1] / a[3], a[2] / a[3]) : glm::vec3(0.0f));
      }
    };
    EnvMap& map = maps[std::size_t(k)];
    if (plan.grid_face) {
      CubeGrid grid(plan.grid_face);
      const int blocks = (grid.side() + kBlock - 1) / kBlock;
      job.progress.check();
      tbb::parallel_for(0, 6 * blocks * blocks, [&](int b) {
        job.progress.check();
        FlushDenormals ftz;
        const int f = b / (blocks * blocks), by = b / blocks % blocks, bx = b % blocks;
        std::vector<glm::dvec3> dirs;
        std::vector<glm::ivec2> at;
        for (int j = by * kBlock; j < std::min(grid.side(), (by + 1) * kBlock); ++j)
          for (int i = bx * kBlock; i < std::min(grid.side(), (bx + 1) * kBlock); ++i) {
            dirs.push_back(grid.dir(f, i, j));
            at.push_back({i, j});
          }
        integrate_block(dirs, [&](std::size_t q, glm::vec3 v) {
          float* out = grid.value(f, at[q].x, at[q].y);
          out[0] = v.x, out[1] = v.y, out[2] = v.z;
        });
      });
      for_each_tile(job.output.tiles(), job.progress, [&](const Tile& tile) {
        job.output.for_each(tile, [&](std::size_t pixel, glm::dvec3 d) {
          const glm::vec3 v = grid.sample(d);
          float* out = map.image.data() + 3 * pixel;
          out[0] = v.x, out[1] = v.y, out[2] = v.z;
        });
        job.progress.tile_done(k, tile);
      });
    } else {
      for_each_tile(job.output.tiles(), job.progress, [&](const Tile& tile) {
        for (int y0 = tile.y; y0 < tile.y + tile.height; y0 += kBlock)
          for (int x0 = tile.x; x0 < tile.x + tile.width; x0 += kBlock) {
            const Tile block{x0, y0, std::min(kBlock, tile.x + tile.width - x0),
                             std::min(kBlock, tile.y + tile.height - y0)};
            std::vector<glm::dvec3> dirs;
            std::vector<std::size_t> pixels;
            job.output.for_each(block, [&](std::size_t pixel, glm::dvec3 d) {
              dirs.push_back(d);
              pixels.push_back(pixel);
            });
            integrate_block(dirs, [&](std::size_t q, glm::vec3 v) {
              float* out = map.image.data() + 3 * pixels[q];
              out[0] = v.x, out[1] = v.y, out[2] = v.z;
            });
          }
        job.progress.tile_done(k, tile);
      });
    }
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    result.seconds[std::size_t(k)] = seconds;
    result.plans[std::size_t(k)] = describe(plan, seconds);
  }
  result.maps = std::move(maps);
  return result;
}

}  // namespace arlight::lighting::detail
