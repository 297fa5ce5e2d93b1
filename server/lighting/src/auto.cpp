// Method `auto`: per shininess s, the cheapest plan that keeps every map within mean 0.5 % and
// max 5 % of `accurate` (thesis eqs. 6.1/6.2), chosen by the lobe's width sigma(s):
//
// 1. Bright lights: texels above kBrightCap x the mean luminance keep the cap, and their excess
//    is summed exactly (Alg. 4.1 over those few texels: 0-1400 of 207k in the bundled probes)
//    and added to whatever handles the rest. They are what breaks every approximation: SH rings
//    around them, prefiltering smears them, interpolation overshoots next to them.
// 2. Wide lobes (SH order sh_order_for(s) <= kMaxShOrder, i.e. s <= ~70): one SH projection
//    (of the input binned to a 96^2 cube, the mean projected exactly), zonal convolution,
//    evaluated on a cube grid kShGridPerSigma points per sigma and interpolated in log space.
//    The irradiance lobe (s < 4) has a kink at the horizon: its SH part (band-limited) is read
//    from a grid in linear space, and its bright lights are summed at every output texel.
// 3. Narrow lobes: direct sums (Alg. 4.1) over the lobe's window (auto_cos_threshold)
//    - of a copy of the input prefiltered to input_per_sigma points per sigma (cube-grid cells
//      that keep their exact power and carry their radiance's first moments, so the lobe's
//      first-order variation over a cell is exact), or the input texels when that is no coarser;
//    - on a cube grid output_per_sigma points per sigma (with a 2-texel border so no lookup
//      crosses a face), read at each output texel by Catmull-Rom interpolation of log radiance,
//      or at every output texel when the grid would not be smaller.
//    Points under a lobe and grid points per lobe are then constant, so every map costs about
//    the same whatever s.
//
// The numbers, measured with compare-style runs on the three bundled probes at 512^2 (all 8
// thesis maps; worst over the probes, max error):
// - input_per_sigma 2 / output 2: s = 320 7.3 %, s = 1280 6.3 %: fails. 2 / 2.5: s = 320 6.8 %.
//   2.5 / 2.5 passes but s = 1280 then needs the raw texels at every output texel: 4 s.
// - 3 / 2.5 (the defaults): s = 160 3.8 %, s = 320 3.9 %, s = 1280 1.7 %, means <= 0.2 %; 8 maps
//   in 0.55 s (make bench). Without the moments, 3 / 3 gave 17 % mean at s = 20 next to a light;
//   interpolating radiance instead of its log gave up to 18.9 % max at s = 80.
// - SH grid at 2 points per sigma: s = 80 4.7 % on studio at 256^2; at 3: 1.5 %.
// Float precision (accumulate_single_f32) changed no error figure above at the 0.1 % level.
// Issue 37 (8 maps at 512^2 in 0.5 -> 0.24 s, make bench): the kernel keeps a group's 2 x 4 power
// chains in registers; each group of 4 directions sums only the cells within its own reach, in
// place; the window's cut is auto's own; the input levels are built while SH runs; the SH part
// of the irradiance map comes from a grid; s = 80 moved from SH (order 41) to direct sums, so the
// SH maps need order 30. No error figure moved by more than 0.05 % mean (s = 80: max 0.9 -> 1.9 %
// on venice, 2.3 -> 3.9 % on studio).
#include <tbb/parallel_for.h>
#include <tbb/task_group.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <glm/exponential.hpp>
#include <glm/geometric.hpp>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <numbers>
#include <numeric>
#include <optional>
#include <sstream>

#include "arlight/common/resample.hpp"
#include "arlight/common/sh.hpp"
#include "direct.hpp"
#include "job.hpp"
#include "kernels.hpp"

namespace arlight::lighting::detail {

namespace {

// Directions integrated together (one gather of nearby points): kBlock x kBlock texels, and
// the points per cell of the inputs. Measured at 512^2, s = 1280: 8 x 8 and 64 points 320 ms;
// 4 x 4 (359 ms), 16 x 16 (413 ms) and 32-point cells (357 ms) all cost more.
constexpr int kBlock = 8;
constexpr int kPointsPerCell = 64;

// Typical spacing (rad) of a cube grid with `face` cells per edge.
double cube_spacing(int face) { return std::sqrt(4.0 * std::numbers::pi / (6.0 * face * face)); }

// The input at several resolutions (face 0: the input texels themselves), each built once:
// prepare() starts building the levels a run will need on TBB's workers, so that they are
// made while the SH stage runs; level() waits for its own.
class InputLevels {
 public:
  explicit InputLevels(const EnvMap& input) : input_(input) {}
  ~InputLevels() {
    try {
      tasks_.wait();
    } catch (...) {  // a level that failed to build throws again where it is used
    }
  }
  InputLevels(const InputLevels&) = delete;
  InputLevels& operator=(const InputLevels&) = delete;

  double full_spacing() const {
    return std::sqrt(4.0 * std::numbers::pi / double(texel_table(input_.layout)->size()));
  }
  void prepare(int face) {
    Slot& slot = slot_of(face);
    tasks_.run([this, face, &slot] { build(face, slot); });
  }
  const PointCells& level(int face) {
    Slot& slot = slot_of(face);
    build(face, slot);
    return *slot.cells;
  }

 private:
  struct Slot {
    std::once_flag once;
    std::unique_ptr<PointCells> cells;
  };
  Slot& slot_of(int face) {
    std::lock_guard lock(mutex_);
    auto& slot = slots_[face];
    if (!slot) slot = std::make_unique<Slot>();
    return *slot;
  }
  void build(int face, Slot& slot) {
    std::call_once(slot.once, [&] {
      slot.cells =
          std::make_unique<PointCells>(face ? points_aggregated(input_, face, kPointsPerCell)
                                            : points_from_texels(input_, kPointsPerCell));
      slot.cells->make_float_copy();
    });
  }

  const EnvMap& input_;
  std::mutex mutex_;
  std::map<int, std::unique_ptr<Slot>> slots_;
  tbb::task_group tasks_;
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
  // The stored values (linear until to_log()), to keep between incremental runs.
  const std::vector<float>& values() const { return values_; }
  void set_values(const std::vector<float>& v) {
    if (v.size() == values_.size()) values_ = v, log_ = false;
  }

  // Direction of grid point (i, j) of face f, i and j from 0 to side-1 (border included).
  glm::dvec3 dir(int f, int i, int j) const {
    const double a = 2.0 * (i - kBorder + 0.5) / face_ - 1.0;
    const double b = 2.0 * (j - kBorder + 0.5) / face_ - 1.0;
    return glm::normalize(normal_[f] + a * right_[f] + b * down_[f]);
  }
  float* value(int f, int i, int j) {
    return values_.data() +
           3 * ((std::size_t(f) * side_ + std::size_t(j)) * side_ + std::size_t(i));
  }

  // Switches the stored values to logarithms (values below `floor` count as `floor`): sample()
  // then interpolates log radiance. A lobe-blurred light is close to a Gaussian, a parabola in
  // log space that the cubic follows closely, so the relative error stays small even in the
  // dark tails next to a bright light, where interpolating radiance itself overshoots.
  void to_log(float floor) {
    for (float& v : values_) v = std::log(std::max(v, floor));
    log_ = true;
  }

  // Where a direction falls: the 4 x 4 texels around it and their Catmull-Rom weights. The
  // same for every grid of the same size, so it is computed once per direction.
  struct Taps {
    std::size_t first;  // float index of the top-left tap
    float wx[4], wy[4];
  };
  Taps taps(glm::dvec3 d) const {
    const int f = EnvLayout::cube_face_of_direction(d);
    const glm::dvec3 p = d / glm::dot(d, normal_[f]);
    const double x = (glm::dot(p, right_[f]) + 1.0) * 0.5 * face_ - 0.5 + kBorder;
    const double y = (glm::dot(p, down_[f]) + 1.0) * 0.5 * face_ - 0.5 + kBorder;
    const int x0 = std::clamp(int(std::floor(x)), 1, side_ - 3);
    const int y0 = std::clamp(int(std::floor(y)), 1, side_ - 3);
    Taps t;
    t.first = 3 * ((std::size_t(f) * side_ + std::size_t(y0 - 1)) * side_ + std::size_t(x0 - 1));
    catmull_rom(float(x - x0), t.wx);
    catmull_rom(float(y - y0), t.wy);
    return t;
  }

  glm::vec3 sample(const Taps& t) const {
    float sum[3] = {0.0f, 0.0f, 0.0f};
    for (int j = 0; j < 4; ++j) {
      const float* v = values_.data() + t.first + 3 * std::size_t(j) * std::size_t(side_);
      float row[3] = {0.0f, 0.0f, 0.0f};
      for (int i = 0; i < 4; ++i)
        for (int c = 0; c < 3; ++c) row[c] += t.wx[i] * v[3 * i + c];
      for (int c = 0; c < 3; ++c) sum[c] += t.wy[j] * row[c];
    }
    if (log_) return {std::exp(sum[0]), std::exp(sum[1]), std::exp(sum[2])};
    // Catmull-Rom can overshoot slightly below 0 next to a sharp highlight; radiance cannot.
    return {std::max(sum[0], 0.0f), std::max(sum[1], 0.0f), std::max(sum[2], 0.0f)};
  }
  glm::vec3 sample(glm::dvec3 d) const { return sample(taps(d)); }

 private:
  static void catmull_rom(float t, float* w) {
    const float t2 = t * t, t3 = t2 * t;
    w[0] = 0.5 * (-t3 + 2 * t2 - t);
    w[1] = 0.5 * (3 * t3 - 5 * t2 + 2);
    w[2] = 0.5 * (-3 * t3 + 4 * t2 + t);
    w[3] = 0.5 * (t3 - t2);
  }

  int face_, side_;
  glm::dvec3 normal_[6], right_[6], down_[6];
  std::vector<float> values_;
  bool log_ = false;
};

struct Plan {
  double sigma;
  int input_face;  // 0: the input texels themselves
  int grid_face;   // 0: integrate at every output texel
};

Plan make_plan(double s, const AutoTuning& tuning, double full_spacing, std::size_t out_texels) {
  Plan p;
  p.sigma = lobe_sigma(s);
  // Wide lobes only come here when the input is too small for SH. Their maps then carry a
  // light's terminator (where cos^s -> 0 and log interpolation fails) within a few sigma, so
  // they get finer spacings, sqrt(40 / s) times: cheap, as the input is small (studio.exr at
  // 128^2, s = 10: 11.4 % max error at 3 / 2.5 points per sigma, 0.6 % with this).
  const double boost = std::max(1.0, std::sqrt(40.0 / s));
  const double input_per_sigma = tuning.input_per_sigma * boost;
  // The coarsest cube grid with input_per_sigma points per sigma, if it is coarser than the
  // input itself (else the input texels are used as they are).
  p.input_face = 0;
  const int face = std::max(
      2, int(std::ceil(std::sqrt(4.0 * std::numbers::pi / 6.0) * input_per_sigma / p.sigma)));
  if (cube_spacing(face) > full_spacing * 1.2) p.input_face = face;
  const int grid = std::max(4, int(std::ceil(std::sqrt(4.0 * std::numbers::pi / 6.0) *
                                             tuning.output_per_sigma * boost / p.sigma)));
  const std::size_t grid_points =
      6 * std::size_t(grid + 2 * CubeGrid::kBorder) * std::size_t(grid + 2 * CubeGrid::kBorder);
  // Interpolating costs next to nothing; the grid pays as soon as it has fewer points.
  // Never across a kink: interpolation would blur the terminator of a bright light (s < 4).
  p.grid_face = grid_points < out_texels && s >= 4.0 ? grid : 0;
  return p;
}

std::string describe(const Plan& p, double seconds) {
  std::ostringstream o;
  o.precision(3);
  o << "auto: sigma " << p.sigma * 180.0 / std::numbers::pi << " deg; input ";
  if (p.input_face)
    o << "prefiltered to a " << p.input_face << "^2 x 6 cube grid";
  else
    o << "texels";
  o << "; output ";
  if (p.grid_face)
    o << "from a " << p.grid_face << "^2 x 6 cube grid (bicubic)";
  else
    o << "texels integrated directly";
  o << "; " << seconds << " s";
  return o.str();
}

// SH order that resolves lobe s: the zonal coefficients of cos^s fall like exp(-l^2 / 2s), so
// bands up to sqrt(2 s ln 1e4) keep all but 1e-4 of the lobe; the clamped cosine (s = 1) falls
// only like l^-2.5 and its kink at the horizon wants more bands than its width suggests.
constexpr int kMinShOrder = 24;
constexpr int kMaxShOrder = 40;
constexpr std::size_t kShProjectionTexels = 60000;
constexpr double kBrightCap = 8.0;
// Grid points per sigma for the SH maps (evaluating SH is cheap next to direct sums).
constexpr double kShGridPerSigma = 3.0;
// Grid points per shortest wavelength (2 pi / order) for the kinked maps' SH parts.
constexpr double kShKinkedGridPerWave = 8.0;
int sh_order_for(double s) {
  return std::max(kMinShOrder, int(std::ceil(std::sqrt(2.0 * s * std::log(1e4)))) + 2);
}

// SH serves lobe s when its order is within kMaxShOrder and the input has enough texels for the
// quadrature: below ~30 texels per coefficient the projection aliases the bright, sharp parts of
// a probe into every band (studio.exr at 128^2: 7 % mean error at s = 10 with order 41), while
// direct sums over so small an input are cheap anyway.
bool sh_resolves(double s, std::size_t input_texels) {
  const int order = sh_order_for(s);
  return order <= kMaxShOrder && std::size_t(order) * std::size_t(order) * 30 <= input_texels;
}

// The input split in two: `rest`, every texel capped at kBrightCap x the mean luminance, and
// `bright`, the few texels' excess over the cap as points carrying radiance but no weight.
// Small, very bright lights are what makes approximations fail (SH rings around them, a
// prefiltered cell smears them); their excess is always integrated exactly (Alg. 4.1 over
// those texels alone) and added to the numerator of whatever handles the rest.
struct BrightSplit {
  EnvMap rest;
  PointCells bright;
  float log_floor;  // 1e-6 x the mean luminance: the darkest value grids interpolate in log
};

BrightSplit split_bright(const EnvMap& input) {
  const auto table = texel_table(input.layout);
  const float* px = input.image.data();
  const auto luminance_at = [](const float* p) {
    return luminance(glm::dvec3(p[0], p[1], p[2]));
  };
  double mean_y = 0.0, total_w = 0.0;
  for (std::size_t i = 0; i < table->size(); ++i) {
    mean_y += table->solid_angle[i] * luminance_at(px + 3 * std::size_t(table->index[i]));
    total_w += table->solid_angle[i];
  }
  const double cap = kBrightCap * mean_y / total_w;
  BrightSplit split{input, {}, float(std::max(1e-30, 1e-6 * mean_y / total_w))};
  EnvMap excess(input.layout);
  for (std::size_t i = 0; i < table->size(); ++i) {
    const std::size_t at = 3 * std::size_t(table->index[i]);
    const double y = luminance_at(px + at);
    if (y <= cap) continue;
    for (int c = 0; c < 3; ++c) {
      split.rest.image.data()[at + c] = float(px[at + c] * cap / y);
      excess.image.data()[at + c] = px[at + c] - split.rest.image.data()[at + c];
    }
  }
  split.bright = points_from_texels(excess, 64, true);
  std::fill(split.bright.w.begin(), split.bright.w.end(), 0.0);
  split.bright.make_float_copy();
  split.bright.make_cell_sums();  // the irradiance lobe's shortcut (BatchIntegrator)
  return split;
}

// The maps whose lobes SH resolve at kMaxShOrder: one projection, evaluated on a cube grid fine
// enough for the narrowest of them and interpolated, except lobes with a kink (s < 4) whose maps
// are evaluated at every output texel (interpolation across the kink of a bright light's
// terminator would show).
void sh_stage(const Job& job, const BrightSplit& split, const std::vector<int>& ks,
              std::vector<EnvMap>& maps, ComputedMapSet& result) {
  const EnvMap& rest = split.rest;
  const PointCells& bright = split.bright;
  const auto table = texel_table(job.input.layout);
  const auto t0 = std::chrono::steady_clock::now();
  int order = 0;
  double narrowest = 1e9;
  std::vector<int> smooth, kinked;
  for (int k : ks) {
    const double s = job.shininess[std::size_t(k)];
    order = std::max(order, sh_order_for(s));
    (s < 4.0 ? kinked : smooth).push_back(k);
    if (s >= 4.0) narrowest = std::min(narrowest, lobe_sigma(s));
  }
  // Project a copy of ~55k texels when the input is larger: order 45 needs no more.
  std::optional<EnvMap> small;
  if (table->size() > kShProjectionTexels)
    small = reduce(rest, EnvLayout::for_size(Projection::Cube, 96));
  const ShPair pair = sh_project_pair(small ? *small : rest, order);
  job.progress.check();
  // Adds the bright texels' exact share to values[k][3 i + c] at dirs[i] for the maps `group`.
  // The sums are normalized by the lobe's integral 2 pi / (s + 1), as the SH convolution is.
  auto add_bright = [&](const std::vector<int>& group, const std::vector<glm::dvec3>& dirs,
                        const std::vector<float*>& values) {
    if (bright.size() == 0 || dirs.empty()) return;
    FlushDenormals ftz;
    std::vector<double> acc(4 * dirs.size());
    for (std::size_t m = 0; m < group.size(); ++m) {
      const double s = job.shininess[std::size_t(group[m])];
      const double one[] = {s};
      const PowerChain chain(one);
      BatchIntegrator(bright, chain, auto_cos_threshold(s)).run(dirs, acc.data());
      const double norm = (s + 1.0) / (2.0 * std::numbers::pi);
      for (std::size_t i = 0; i < dirs.size(); ++i)
        for (int c = 0; c < 3; ++c)
          values[m][3 * i + std::size_t(c)] += float(acc[4 * i + std::size_t(c)] * norm);
    }
  };
  // Each group at the order its narrowest lobe needs (the kinked irradiance lobes need far fewer
  // bands than the sharpest smooth one): radiance and weight expansions (sh_method.cpp).
  auto convolved = [&](const std::vector<int>& group) {
    int n = 1;
    std::vector<double> s;
    for (int k : group) {
      n = std::max(n, sh_order_for(job.shininess[std::size_t(k)]));
      s.push_back(job.shininess[std::size_t(k)]);
    }
    return sh_convolve_pair(pair, n, s);
  };
  // Evaluates `coeffs` at every point of `grids` (equal grids, one an output of the
  // expansions; `scratch` more outputs are evaluated into rows not kept), then finish(dirs, out)
  // on each row of points.
  const auto evaluate_on = [&](std::vector<CubeGrid>& grids, const std::vector<ShCoeffs>& coeffs,
                               std::size_t scratch, const auto& finish) {
    const int side = grids[0].side();
    tbb::parallel_for(0, 6 * side, [&](int row) {
      job.progress.check();
      const int f = row / side, j = row % side;
      std::vector<glm::dvec3> dirs;
      for (int i = 0; i < side; ++i) dirs.push_back(grids[0].dir(f, i, j));
      std::vector<std::vector<float>> rows(scratch, std::vector<float>(3 * dirs.size()));
      std::vector<float*> out;
      for (CubeGrid& g : grids) out.push_back(g.value(f, 0, j));
      for (auto& r : rows) out.push_back(r.data());
      sh_evaluate_many(coeffs, dirs, out);
      finish(dirs, out);
    });
  };
  std::vector<CubeGrid> grids;
  if (!smooth.empty()) {
    const int face = std::max(
        4, int(std::ceil(std::sqrt(4.0 * std::numbers::pi / 6.0) * kShGridPerSigma / narrowest)));
    for (std::size_t i = 0; i < smooth.size(); ++i) grids.emplace_back(face);
    evaluate_on(grids, convolved(smooth), sh_pair_outputs(smooth.size()) - smooth.size(),
                [&](const std::vector<glm::dvec3>& dirs, const std::vector<float*>& out) {
                  add_bright(smooth, dirs, out);  // numerators only: the first outputs
                  sh_divide(out, smooth.size(), dirs.size());
                });
    for (CubeGrid& g : grids) g.to_log(split.log_floor);
  }
  const std::vector<ShCoeffs> kinked_coeffs = convolved(kinked);
  // The kinked maps' SH parts (numerators and weights) are band-limited at their order: on a
  // cube grid kShKinkedGridPerWave points per shortest wavelength, interpolated in linear space,
  // when that grid is smaller than the output. The kink itself comes from the bright texels,
  // which are still summed exactly at every output texel.
  std::vector<CubeGrid> kinked_grids;
  if (!kinked.empty()) {
    const int order = kinked_coeffs[0].order;
    const int face = int(std::ceil(std::sqrt(4.0 * std::numbers::pi / 6.0) * kShKinkedGridPerWave *
                                   order / (2.0 * std::numbers::pi)));
    const std::size_t side = std::size_t(face + 2 * CubeGrid::kBorder);
    if (6 * side * side < texel_table(job.output.layout())->size()) {
      for (std::size_t i = 0; i < kinked_coeffs.size(); ++i) kinked_grids.emplace_back(face);
      evaluate_on(kinked_grids, kinked_coeffs, 0,
                  [](const std::vector<glm::dvec3>&, const std::vector<float*>&) {});
    }
  }
  for_each_tile(job.output.tiles(), job.progress, [&](const Tile& tile) {
    const auto [dirs, pixels] = job.output.collect(tile);
    if (!smooth.empty())
      for (std::size_t t = 0; t < dirs.size(); ++t) {
        const CubeGrid::Taps taps = grids[0].taps(dirs[t]);
        for (std::size_t i = 0; i < smooth.size(); ++i) {
          const glm::vec3 v = grids[i].sample(taps);
          float* out = maps[std::size_t(smooth[i])].image.data() + 3 * pixels[t];
          out[0] = v.x, out[1] = v.y, out[2] = v.z;
        }
      }
    if (!kinked.empty()) {
      std::vector<std::vector<float>> values(sh_pair_outputs(kinked.size()),
                                             std::vector<float>(3 * dirs.size()));
      std::vector<float*> out;
      for (auto& v : values) out.push_back(v.data());
      if (kinked_grids.empty()) {
        sh_evaluate_many(kinked_coeffs, dirs, out);
      } else {
        for (std::size_t t = 0; t < dirs.size(); ++t) {
          const CubeGrid::Taps taps = kinked_grids[0].taps(dirs[t]);
          for (std::size_t i = 0; i < kinked_grids.size(); ++i) {
            const glm::vec3 v = kinked_grids[i].sample(taps);
            out[i][3 * t] = v.x, out[i][3 * t + 1] = v.y, out[i][3 * t + 2] = v.z;
          }
        }
      }
      add_bright(kinked, dirs, out);
      sh_divide(out, kinked.size(), dirs.size());
      for (std::size_t i = 0; i < kinked.size(); ++i)
        for (std::size_t t = 0; t < pixels.size(); ++t)
          for (int c = 0; c < 3; ++c)
            maps[std::size_t(kinked[i])].image.data()[3 * pixels[t] + c] =
                std::max(0.0f, values[i][3 * t + c]);
    }
    for (int k : ks) job.progress.tile_done(k, tile);
  });
  const double seconds = seconds_since(t0);
  for (int k : ks) {
    result.seconds[std::size_t(k)] = seconds / double(ks.size());
    std::ostringstream o;
    o.precision(3);
    const bool kink = job.shininess[std::size_t(k)] < 4.0;
    int n = 1;
    for (int j : kink ? kinked : smooth)
      n = std::max(n, sh_order_for(job.shininess[std::size_t(j)]));
    o << "auto: SH order " << n << " (one projection for " << ks.size() << " maps), "
      << (!kink ? "evaluated on a " + std::to_string(grids[0].side() - 4) +
                      "^2 x 6 cube grid (bicubic)"
          : kinked_grids.empty()
              ? std::string("evaluated at every texel")
              : "its SH part from a " + std::to_string(kinked_grids[0].side() - 4) +
                    "^2 x 6 cube grid (bicubic, linear), bright lights (" +
                    std::to_string(bright.size()) + " texels) at every texel")
      << "; " << seconds << " s for the group";
    result.plans[std::size_t(k)] = o.str();
  }
}

// How far the changes of an incremental run reach for lobe s. A changed texel at angle theta
// from an output direction moves the output's value by at most cos^s(theta) x its change x
// (s + 1) / 2 pi (the lobe's integral normalises the sums); bounding the changes by their total,
// memory.changed_power, an output group whose nearest changed cone lies at theta may be skipped
// while the sum of those bounds over the runs it skipped (its debt) stays within the tolerance
// of its darkest value (plus 1 % of the input's mean luminance, so black outputs need not be
// exact to the last photon). Changes beyond the integrator's window never reach it.
class ChangeReach {
 public:
  ChangeReach(const AutoMemory& memory, double s, double window, double cell_radius)
      : memory_(memory),
        s_(s),
        window_(window),
        cell_radius_(cell_radius),
        scale_(memory.changed_power * (s + 1.0) / (2.0 * std::numbers::pi)) {}

  bool must_recompute(std::span<const glm::dvec3> group, float darkest, float& debt) const {
    const Cone cone = bounding_cone(group);
    double nearest = -1.0;
    for (const glm::dvec3& c : memory_.changed)
      nearest = std::max(nearest, glm::dot(c, cone.centre));
    // The least angle between an output of the group and a point a changed texel moved.
    const double theta =
        std::acos(std::clamp(nearest, -1.0, 1.0)) - cone.radius - memory_.max_radius - cell_radius_;
    if (theta >= window_) return false;
    const double bound = theta <= 0.0 ? scale_ : std::pow(std::cos(theta), s_) * scale_;
    const double budget = memory_.tolerance * (std::max(0.0f, darkest) + 0.01 * memory_.mean);
    if (double(debt) + bound <= budget) {
      debt += float(bound);
      return false;
    }
    debt = 0.0f;
    return true;
  }

 private:
  const AutoMemory& memory_;
  double s_, window_, cell_radius_, scale_;
};

// One narrow lobe by direct sums (step 3 above), on its cube grid or at every output texel. An
// incremental run recomputes a 4 x 4 group of outputs only when the changes could have moved it
// by more than the budget since it was last computed (ChangeReach, with the debts of the groups
// it skipped, indexed by block x 4 + group).
class DirectLobe {
 public:
  DirectLobe(const Job& job, const BrightSplit& split, InputLevels& levels, std::size_t out_texels,
             AutoMemory* memory, int k)
      : job_(job),
        split_(split),
        k_(k),
        s_(job.shininess[std::size_t(k)]),
        plan_(make_plan(s_, job.spec.tuning, levels.full_spacing(), out_texels)),
        pts_(levels.level(plan_.input_face)),
        chain_(std::span<const double>(&s_, 1)),
        min_cos_(auto_cos_threshold(s_)),
        incremental_(memory && memory->valid),
        memory_(memory) {
    if (!memory) return;
    memory->debt.resize(job.shininess.size());
    debt_ = &memory->debt[std::size_t(k)];
    const std::size_t side =
        plan_.grid_face ? std::size_t(plan_.grid_face + 2 * CubeGrid::kBorder) : 0;
    const std::size_t groups =
        4 * (plan_.grid_face ? 6 * side * side : job.output.layout().texel_count());
    if (!incremental_ || debt_->size() != groups) debt_->assign(groups, 0.0f);
    if (incremental_)
      reach_.emplace(*memory, s_, std::acos(std::clamp(min_cos_, -1.0, 1.0)),
                     plan_.input_face ? 3.0 / plan_.input_face : 0.0);
  }

  // Computes `map` (holding its last values in an incremental run); with a memory, the cube
  // grid's values are kept in grid_values for the next run.
  void run(EnvMap& map, std::vector<float>& grid_values) {
    if (plan_.grid_face)
      run_on_grid(map, grid_values);
    else
      run_on_texels(map);
  }
  const Plan& plan() const { return plan_; }
  // The share of the outputs this run recomputed.
  double recomputed() const {
    return double(outputs_done_) / double(std::max<std::size_t>(1, outputs_total_));
  }

 private:
  // Integrates up to kBlock x kBlock nearby directions (local[i]: their places in the block)
  // into slot(i), the output's RGB (holding its last value in an incremental run). `block`
  // numbers the block for the debts.
  template <class Slot>
  void integrate_block(std::size_t block, const std::vector<glm::dvec3>& all,
                       const std::vector<glm::ivec2>& local, Slot&& slot) {
    outputs_total_ += all.size();
    std::vector<std::size_t> picked;
    if (reach_) {
      for (int g = 0; g < 4; ++g) {
        std::vector<std::size_t> in;
        std::vector<glm::dvec3> group;
        float darkest = std::numeric_limits<float>::max();
        for (std::size_t i = 0; i < all.size(); ++i)
          if (int(local[i].x >= kBlock / 2) + 2 * int(local[i].y >= kBlock / 2) == g) {
            in.push_back(i), group.push_back(all[i]);
            const float* v = slot(i);
            darkest = std::min({darkest, v[0], v[1], v[2]});
          }
        if (!group.empty() &&
            reach_->must_recompute(group, darkest, (*debt_)[4 * block + std::size_t(g)]))
          picked.insert(picked.end(), in.begin(), in.end());
      }
    } else {
      picked.resize(all.size());
      std::iota(picked.begin(), picked.end(), std::size_t(0));
    }
    if (picked.empty()) return;
    outputs_done_ += picked.size();
    std::vector<glm::dvec3> dirs;
    for (std::size_t i : picked) dirs.push_back(all[i]);
    BatchIntegrator batch(pts_, chain_, min_cos_);
    std::vector<double> acc(4 * dirs.size()), lights(4 * dirs.size(), 0.0);
    batch.run(dirs, acc.data());
    if (split_.bright.size() > 0) {
      BatchIntegrator exact(split_.bright, chain_, min_cos_);
      exact.run(dirs, lights.data());
    }
    for (std::size_t i = 0; i < dirs.size(); ++i) {
      const double* a = acc.data() + 4 * i;
      const double* b = lights.data() + 4 * i;
      float* out = slot(picked[i]);
      for (int c = 0; c < 3; ++c) out[c] = a[3] > 0.0 ? float((a[c] + b[c]) / a[3]) : 0.0f;
    }
  }

  // On the plan's cube grid, then read at each output texel (Catmull-Rom of log radiance).
  void run_on_grid(EnvMap& map, std::vector<float>& grid_values) {
    CubeGrid grid(plan_.grid_face);
    if (incremental_) grid.set_values(memory_->grids[std::size_t(k_)]);
    const int blocks = (grid.side() + kBlock - 1) / kBlock;
    job_.progress.check();
    tbb::parallel_for(0, 6 * blocks * blocks, [&](int b) {
      job_.progress.check();
      FlushDenormals ftz;
      const int f = b / (blocks * blocks), by = b / blocks % blocks, bx = b % blocks;
      std::vector<glm::dvec3> dirs;
      std::vector<glm::ivec2> at, local;
      for (int j = by * kBlock; j < std::min(grid.side(), (by + 1) * kBlock); ++j)
        for (int i = bx * kBlock; i < std::min(grid.side(), (bx + 1) * kBlock); ++i) {
          dirs.push_back(grid.dir(f, i, j));
          at.push_back({i, j});
          local.push_back({i - bx * kBlock, j - by * kBlock});
        }
      integrate_block(std::size_t(b), dirs, local,
                      [&](std::size_t q) { return grid.value(f, at[q].x, at[q].y); });
    });
    if (memory_) grid_values = grid.values();
    grid.to_log(split_.log_floor);
    for_each_tile(job_.output.tiles(), job_.progress, [&](const Tile& tile) {
      job_.output.for_each(tile, [&](std::size_t pixel, glm::dvec3 d) {
        const glm::vec3 v = grid.sample(d);
        float* out = map.image.data() + 3 * pixel;
        out[0] = v.x, out[1] = v.y, out[2] = v.z;
      });
      job_.progress.tile_done(k_, tile);
    });
  }

  // At every output texel, kBlock x kBlock texels at a time.
  void run_on_texels(EnvMap& map) {
    const std::size_t w = std::size_t(job_.output.layout().width());
    for_each_tile(job_.output.tiles(), job_.progress, [&](const Tile& tile) {
      for (int y0 = tile.y; y0 < tile.y + tile.height; y0 += kBlock)
        for (int x0 = tile.x; x0 < tile.x + tile.width; x0 += kBlock) {
          const Tile block{x0, y0, std::min(kBlock, tile.x + tile.width - x0),
                           std::min(kBlock, tile.y + tile.height - y0)};
          const TileTexels texels = job_.output.collect(block);
          if (texels.dirs.empty()) continue;
          std::vector<glm::ivec2> local;
          for (std::size_t pixel : texels.pixels)
            local.push_back({int(pixel % w) - x0, int(pixel / w) - y0});
          integrate_block(std::size_t(y0) * w + std::size_t(x0), texels.dirs, local,
                          [&](std::size_t q) { return map.image.data() + 3 * texels.pixels[q]; });
        }
      job_.progress.tile_done(k_, tile);
    });
  }

  const Job& job_;
  const BrightSplit& split_;
  int k_;
  double s_;
  Plan plan_;
  const PointCells& pts_;
  PowerChain chain_;
  double min_cos_;
  bool incremental_;
  AutoMemory* memory_;
  std::optional<ChangeReach> reach_;
  std::vector<float>* debt_ = nullptr;
  std::atomic<std::size_t> outputs_done_ = 0, outputs_total_ = 0;
};

}  // namespace

ComputedMapSet run_auto(const Job& job, AutoMemory* memory) {
  const int count = int(job.shininess.size());
  const bool incremental = memory && memory->valid;
  ComputedMapSet result;
  result.seconds.assign(std::size_t(count), 0.0);
  result.plans.assign(std::size_t(count), "");
  if (incremental && memory->changed.empty()) {  // nothing changed: the last maps stand
    result.maps = memory->maps;
    result.plans.assign(std::size_t(count), "auto: input unchanged, maps kept");
    memory->recomputed.assign(std::size_t(count), 0.0);
    return result;
  }
  const auto t_split = std::chrono::steady_clock::now();
  const BrightSplit split = split_bright(job.input);
  const double split_seconds = seconds_since(t_split);
  InputLevels levels(split.rest);
  const std::size_t out_texels = texel_table(job.output.layout())->size();
  std::vector<EnvMap> maps = incremental ? memory->maps : blank_maps(job);
  std::vector<double> recomputed(std::size_t(count), 1.0);
  // Wide lobes by SH, first (cheapest, so a consumer gets usable maps early). Their windows
  // reach most of the sphere: any change recomputes them whole.
  const std::size_t sh_samples =
      std::min<std::size_t>(texel_table(job.input.layout)->size(), kShProjectionTexels);
  std::vector<int> by_sh, direct;
  for (int k : ascending_order(job.shininess))
    (sh_resolves(job.shininess[std::size_t(k)], sh_samples) ? by_sh : direct).push_back(k);
  for (int k : direct)
    levels.prepare(
        make_plan(job.shininess[std::size_t(k)], job.spec.tuning, levels.full_spacing(), out_texels)
            .input_face);
  if (!by_sh.empty()) sh_stage(job, split, by_sh, maps, result);
  std::vector<std::vector<float>> grids(maps.size());
  // Narrow lobes by direct integration over prefiltered input, widest first.
  for (int k : direct) {
    const auto t0 = std::chrono::steady_clock::now();
    DirectLobe lobe(job, split, levels, out_texels, memory, k);
    lobe.run(maps[std::size_t(k)], grids[std::size_t(k)]);
    const double seconds = seconds_since(t0);
    recomputed[std::size_t(k)] = lobe.recomputed();
    result.seconds[std::size_t(k)] = seconds + split_seconds / count;
    result.plans[std::size_t(k)] = describe(lobe.plan(), seconds);
    if (incremental) {
      std::ostringstream o;
      o.precision(3);
      o << "; incremental: " << 100.0 * recomputed[std::size_t(k)] << " % recomputed";
      result.plans[std::size_t(k)] += o.str();
    }
  }
  if (memory) {
    memory->maps = maps;
    memory->grids = std::move(grids);
    memory->recomputed = std::move(recomputed);
    memory->valid = true;
  }
  result.maps = std::move(maps);
  return result;
}

}  // namespace arlight::lighting::detail
