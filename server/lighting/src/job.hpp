// What every method implementation gets: the request, the output texels, tiling, progress and
// cancellation.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <span>
#include <string>
#include <vector>

#include "arlight/common/brdf.hpp"
#include "arlight/common/sh.hpp"
#include "arlight/lighting/lighting.hpp"

namespace arlight::lighting::detail {

struct Tile {
  int x, y, width, height;
};

// The directions and pixels of a tile's valid texels, as parallel arrays (for batched sums).
struct TileTexels {
  std::vector<glm::dvec3> dirs;
  std::vector<std::size_t> pixels;
};

// The output layout's valid texels, addressable by pixel.
class OutputTexels {
 public:
  // Tiles of tile x tile texels; cube faces split at face borders.
  explicit OutputTexels(const EnvLayout& layout, int tile = 32);
  const EnvLayout& layout() const { return table_->layout; }
  const std::vector<Tile>& tiles() const { return tiles_; }
  // Calls fn(pixel, direction) for every valid texel of `tile` (pixel = y * width + x).
  template <class Fn>
  void for_each(const Tile& tile, Fn&& fn) const {
    const int w = layout().width();
    for (int y = tile.y; y < tile.y + tile.height; ++y)
      for (int x = tile.x; x < tile.x + tile.width; ++x) {
        const std::size_t pixel = std::size_t(y) * std::size_t(w) + std::size_t(x);
        const std::int32_t e = entry_[pixel];
        if (e >= 0) fn(pixel, glm::dvec3(table_->x[e], table_->y[e], table_->z[e]));
      }
  }
  TileTexels collect(const Tile& tile) const {
    TileTexels t;
    for_each(tile, [&](std::size_t pixel, glm::dvec3 d) {
      t.dirs.push_back(d);
      t.pixels.push_back(pixel);
    });
    return t;
  }

 private:
  std::shared_ptr<const TexelTable> table_;
  std::vector<std::int32_t> entry_;  // index into table_, -1 off the sphere
  std::vector<Tile> tiles_;
};

// Progress reporting and cancellation shared by the computing threads.
class Progress {
 public:
  Progress(const Hooks& hooks, std::size_t total) : hooks_(hooks), total_(total) {}
  // Between steps: throws Cancelled once a stop has been requested; lets more urgent work go
  // first (Hooks::step_aside).
  void check() const {
    if (hooks_.stop.stop_requested()) throw Cancelled();
    if (hooks_.step_aside) hooks_.step_aside();
  }
  void tile_done(int map, const Tile& tile);

 private:
  const Hooks& hooks_;
  std::size_t total_;
  std::size_t done_ = 0;
  std::mutex mutex_;
};

// Runs fn(tile) for every tile on all cores with denormals flushed; checks for cancellation
// before each tile.
void for_each_tile(std::span<const Tile> tiles, const Progress& progress,
                   const std::function<void(const Tile&)>& fn);

struct Job {
  const EnvMap& input;
  std::vector<double> shininess;  // as requested
  const OutputTexels& output;
  const MethodSpec& spec;
  Progress& progress;
};

using arlight::radical_inverse;  // common/brdf.hpp

// Seconds since t0.
double seconds_since(std::chrono::steady_clock::time_point t0);

// The result of a method that makes all its maps in one pass started at t0: the pass's time is
// shared equally between the maps (ComputedMapSet::seconds).
ComputedMapSet joint_result(std::vector<EnvMap> maps, std::chrono::steady_clock::time_point t0,
                    std::vector<std::string> plans);

// Maps of one job, all zero, in the output layout.
std::vector<EnvMap> blank_maps(const Job& job);

// Sort order of a job's shininess (ascending), as indices into job.shininess.
std::vector<int> ascending_order(std::span<const double> shininess);

// Standard deviation (radians, per axis) of the normalized lobe max(0, cos)^s: the width the
// methods compare with texel spacings. 1/sqrt(s) for large s; ~0.66 for the cosine lobe.
double lobe_sigma(double s);

// SH projections (thesis Alg. 4.5) of an environment's radiance and of its texels' weights (the
// constant 1 under the same quadrature). Convolving both with a lobe and dividing gives Alg.
// 4.1's ratio sum L w K / sum w K for the lobe K truncated to the order.
struct ShPair {
  ShCoeffs radiance, weight;
};
ShPair sh_project_pair(const EnvMap& env, int order);
// For each shininess the convolved radiance expansion, then the weight expansions three maps to
// one (channel j of expansion maps + k/3 is map k's weight), all truncated to `order` (<= the
// pair's): sh_pair_outputs(maps) expansions for one evaluation.
std::vector<ShCoeffs> sh_convolve_pair(const ShPair& pair, int order,
                                       std::span<const double> shininess);
std::size_t sh_pair_outputs(std::size_t maps);
// Divides each map's evaluated radiance (values[k], count directions x 3 channels) by its
// evaluated weight.
void sh_divide(std::span<float* const> values, std::size_t maps, std::size_t count);

ComputedMapSet run_direct(const Job& job, bool bounded);  // accurate, bounded
ComputedMapSet run_mipmap(const Job& job);
ComputedMapSet run_sh(const Job& job);
ComputedMapSet run_importance(const Job& job);
// What method auto keeps from one input to the next when it follows a changing environment
// (MapUpdater): its last maps and cube grids, and where the new input changed. A run with a
// memory that is not valid computes everything and fills it. (The bright split is made afresh
// every run: its cap only decides which part of the input is summed exactly, so outputs kept
// from a run with another cap differ from recomputed ones by the method's own error at most.)
struct AutoMemory {
  bool valid = false;
  std::vector<EnvMap> maps;
  std::vector<std::vector<float>> grids;  // per map: its cube grid's values (linear), if any
  // Cones (unit centre, angular radius) holding every input texel that changed since the last
  // run; max_radius bounds the radii.
  std::vector<glm::dvec3> changed;
  double max_radius = 0.0;
  // Their total change, sum over the changed texels of max_c |change_c| x solid angle.
  double changed_power = 0.0;
  // The relative drift a map value may take from the changes it skips before it is recomputed,
  // and the input's mean luminance (for the dark floor).
  double tolerance = 0.0, mean = 0.0;
  std::vector<std::vector<float>> debt;  // per map: the drift bounds of skipped output groups
  std::vector<double> recomputed;  // out: the share of each map's output recomputed
};

ComputedMapSet run_auto(const Job& job, AutoMemory* memory = nullptr);

// Where an input changed since `base` (same layout), which takes the changed texels' new values
// (MapUpdater, GgxUpdater). A texel counts as changed when a channel moved by more than
// `tolerance` x (its larger value + a tenth of the mean luminance), or by `estimated_tolerance`
// x that where `measured` (one share per texel, or empty: all measured) says it was estimated.
struct InputChanges {
  // Cones holding every changed texel: unit centre, angular radius and the sum of
  // max_c |change_c| x solid angle over their texels.
  std::vector<glm::dvec3> centre;
  std::vector<double> radius, power;
  double max_radius = 0.0, changed_power = 0.0;  // over all cones
  double mean = 0.0;   // the input's mean luminance
  double share = 0.0;  // of the input's texels that changed
};
InputChanges find_changes(const EnvMap& input, EnvMap& base, double tolerance,
                          std::span<const float> measured, double estimated_tolerance);
// Throws std::invalid_argument unless `measured` is empty or has one share per input texel.
void check_measured(const EnvMap& input, std::span<const float> measured, const char* who);

// Throws std::invalid_argument for an empty list or a shininess below 1.
void check_shininess(std::span<const double> shininess);
// compute_maps() over prepared output texels, with method auto's memory (may be null).
ComputedMapSet compute(const EnvMap& input, std::span<const double> shininess, const OutputTexels& texels,
               const MethodSpec& method, const Hooks& hooks, AutoMemory* memory);

}  // namespace arlight::lighting::detail
