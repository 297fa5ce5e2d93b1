// The estimate of the unseen directions (issue 16 §1); the model is described in
// arlight/capture/fill.hpp.
#include "arlight/capture/fill.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <glm/common.hpp>
#include <glm/geometric.hpp>
#include <limits>
#include <map>
#include <mutex>
#include <numbers>
#include <opencv2/core.hpp>
#include <stdexcept>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "arlight/common/error.hpp"
#include "equal_area_grid.hpp"

namespace arlight::capture {

std::string_view fill_name(Fill fill) {
  switch (fill) {
    case Fill::None:
      return "none";
    case Fill::Mean:
      return "mean";
    case Fill::Estimate:
      return "estimate";
  }
  return "?";
}

std::optional<Fill> parse_fill(std::string_view name) {
  for (Fill f : {Fill::None, Fill::Mean, Fill::Estimate})
    if (name == fill_name(f)) return f;
  return std::nullopt;
}

Fill fill_from_name(std::string_view name, std::string_view what) {
  if (const auto f = parse_fill(name)) return *f;
  throw InputError((what.empty() ? std::string() : std::string(what) + ": ") +
                   "expected none, mean or estimate, got '" + std::string(name) + "'");
}

namespace {

// A zone of the profile counts as seen when at least 0.1 % of its solid angle (`total`) was
// measured (its weight `measured`: solid angle x confidence).
bool zone_seen(double measured, double total) { return measured > 1e-3 * total; }

using Grid = EqualAreaGrid;

// Where each texel of a layout falls on the grid: the same for every estimator of a layout
// (a pass over every texel, ~10 ms at arlightd's layout, that each session used to repeat when
// it started).
struct CellGeometry {
  // Per texel of the layout, in its own order (fit() streams them): the cell and the solid
  // angle (0 off the sphere).
  std::vector<std::uint32_t> texel_cell;
  std::vector<float> texel_omega;
  std::vector<double> cell_total;    // solid angle of each cell's texels
  std::vector<glm::dvec3> cell_dir;  // the solid-angle-weighted mean direction, normalised

  // The SH basis at every cell's direction, for unseen_sh(order): made once per order.
  mutable std::mutex basis_mutex;
  mutable std::map<int, std::shared_ptr<const std::vector<double>>> basis_by_order;
};

std::shared_ptr<const CellGeometry> make_cell_geometry(const EnvLayout& layout, const Grid& grid) {
  const auto table = texel_table(layout);
  auto g = std::make_shared<CellGeometry>();
  g->texel_cell.assign(layout.texel_count(), 0);
  g->texel_omega.assign(layout.texel_count(), 0.0f);
  g->cell_total.assign(std::size_t(grid.size()), 0.0);
  g->cell_dir.assign(std::size_t(grid.size()), glm::dvec3(0.0));
  for (std::size_t i = 0; i < table->size(); ++i) {
    const glm::dvec3 d(table->x[i], table->y[i], table->z[i]);
    const auto c = std::size_t(grid.cell(d));
    g->texel_cell[table->index[i]] = std::uint32_t(c);
    g->texel_omega[table->index[i]] = float(table->solid_angle[i]);
    g->cell_total[c] += table->solid_angle[i];
    g->cell_dir[c] += table->solid_angle[i] * d;
  }
  for (glm::dvec3& d : g->cell_dir)
    if (glm::dot(d, d) > 0.0) d = glm::normalize(d);
  return g;
}

// Cached like texel_table(): the last few layouts and grids asked for (thread-safe).
std::shared_ptr<const CellGeometry> cell_geometry(const EnvLayout& layout, const Grid& grid) {
  using Key = std::tuple<int, int, int, int>;
  static std::mutex mutex;
  static std::vector<std::pair<Key, std::shared_ptr<const CellGeometry>>> cache;
  const Key key{int(layout.projection()), layout.width(), layout.height(), grid.zones};
  std::lock_guard lock(mutex);
  for (const auto& [k, g] : cache)
    if (k == key) return g;
  auto g = make_cell_geometry(layout, grid);
  if (cache.size() >= 8) cache.erase(cache.begin());
  cache.emplace_back(key, g);
  return g;
}

}  // namespace

struct UnseenEstimator::Impl {
  EnvLayout layout;
  Fill fill;
  FillOptions options;
  std::shared_ptr<const TexelTable> table;
  Grid grid;
  std::shared_ptr<const CellGeometry> geometry;  // shared by every estimator of this layout

  // The fit.
  bool any_seen = false;
  double measured = 0.0;               // solid angle measured
  std::vector<double> cell_seen;       // solid angle measured per cell
  glm::dvec3 mean{0.0};                // mean seen radiance (Fill::Mean, and the last resort)
  std::vector<glm::dvec3> zone_value;  // the profile Z at zone centres
  ShCoeffs residual;
  std::vector<glm::dvec3> cell_model;  // the model at each cell's direction (unseen_sh)
  std::vector<glm::dvec3> cell_seen_radiance;  // mean measured radiance, lights unclipped
  std::vector<float> texel_luminance;  // fit()'s scratch, kept to spare the allocation

  Impl(const EnvLayout& l, Fill f, FillOptions o) : layout(l), fill(f), options(o) {
    if (o.zones < 2 || o.zones > 256)
      throw std::invalid_argument("fill: zones must be in [2, 256], got " +
                                  std::to_string(o.zones));
    if (o.residual_order < 0 || o.residual_order > 8)
      throw std::invalid_argument("fill: residual order must be in [0, 8], got " +
                                  std::to_string(o.residual_order));
    if (o.residual_order > 0 && !(o.ridge > 0.0 && std::isfinite(o.ridge)))
      throw std::invalid_argument("fill: ridge must be a positive number");
    if (!(o.clip_quantile > 0.0 && o.clip_quantile <= 1.0))
      throw std::invalid_argument("fill: clip quantile must be in (0, 1]");
    if (!(o.trend_limit >= 1.0 && std::isfinite(o.trend_limit)) || o.trend_zones < 2)
      throw std::invalid_argument("fill: trend limit must be >= 1 and trend zones >= 2");
    if (!(o.ground_albedo >= 0.0 && o.ground_albedo <= 1.0))
      throw std::invalid_argument("fill: ground albedo must be in [0, 1]");
    table = texel_table(layout);
    grid = {o.zones, 2 * o.zones};
    geometry = cell_geometry(layout, grid);
    cell_seen.assign(geometry->cell_total.size(), 0.0);
    zone_value.assign(std::size_t(grid.zones), glm::dvec3(0.0));
  }

  // Z(y): linear between zone centres, constant beyond the outermost.
  glm::dvec3 profile(double y) const {
    const double u = (y + 1.0) * 0.5 * grid.zones - 0.5;
    const int z0 = std::clamp(int(std::floor(u)), 0, grid.zones - 1);
    const int z1 = std::min(z0 + 1, grid.zones - 1);
    const double f = std::clamp(u - z0, 0.0, 1.0);
    return (1.0 - f) * zone_value[std::size_t(z0)] + f * zone_value[std::size_t(z1)];
  }

  glm::dvec3 model(const glm::dvec3& d) const {
    if (fill == Fill::None || !any_seen) return glm::dvec3(0.0);
    if (fill == Fill::Mean) return mean;
    glm::dvec3 l = profile(d.y);
    if (residual.order > 0) {
      double basis[64];
      sh_basis_all(residual.order, d, std::span<double>(basis, std::size_t(residual.c.size())));
      for (std::size_t k = 0; k < residual.c.size(); ++k) l += basis[k] * residual.c[k];
    }
    return glm::max(l, glm::dvec3(0.0));
  }

  void fit(const MeasuredTexels& m);
  // The SH basis at every cell's direction (cached per order).
  std::shared_ptr<const std::vector<double>> basis_of_cells(int order) const;
  void fit_profile(const std::vector<double>& w, const std::vector<glm::dvec3>& rw,
                   const std::vector<glm::dvec3>& rw_lights);
  void lean_towards_the_ground(int bottom, const std::vector<double>& zw,
                               const std::vector<double>& zt,
                               const std::vector<glm::dvec3>& zrw_lights);
  void fit_residual(const std::vector<double>& w, const std::vector<glm::dvec3>& rw);
};

void UnseenEstimator::Impl::fit(const MeasuredTexels& m) {
  const std::size_t texels = layout.texel_count();
  if (m.weight.size() != texels || m.weighted_radiance.size() != 3 * texels)
    throw std::invalid_argument("fill: " + std::to_string(m.weight.size()) + " weights and " +
                                std::to_string(m.weighted_radiance.size()) +
                                " radiance values do not fit a map of " + std::to_string(texels) +
                                " texels");
  // Per cell: sum of solid angle x confidence (w), of that times radiance (rw), and the solid
  // angle measured at all; per texel in float, per cell in double. One pass over the texels
  // in the layout's order sums them unclipped; the lights are clipped afterwards, texel by
  // texel, once the quantile is known (~0.8 ms for a 512x512 map on one core).
  std::vector<double> w(geometry->cell_total.size(), 0.0);
  std::vector<glm::dvec3> rw(geometry->cell_total.size(), glm::dvec3(0.0));
  std::fill(cell_seen.begin(), cell_seen.end(), 0.0);
  measured = 0.0;
  // And a histogram of the luminance by solid angle: bins of 1/16 of an octave (the float's
  // exponent and top four mantissa bits) over 2^-32 .. 2^32.
  constexpr int kSub = 16, kOctaves = 64, kBins = kSub * kOctaves;
  std::vector<double> histogram(kBins, 0.0);
  texel_luminance.assign(texels, -1.0f);  // -1: not measured, or not a usable value
  for (std::size_t t = 0; t < texels; ++t) {
    const float sw = m.weight[t], omega = geometry->texel_omega[t];
    if (!(sw > 0.0f && sw <= std::numeric_limits<float>::max()) || omega == 0.0f) continue;
    const float* p = &m.weighted_radiance[3 * t];
    const float r = p[0] / sw, g = p[1] / sw, b = p[2] / sw;
    if (!(r >= 0.0f && g >= 0.0f && b >= 0.0f && r + g + b <= std::numeric_limits<float>::max()))
      continue;
    const float y = std::max(luminance(r, g, b), 1e-30f);
    texel_luminance[t] = y;
    const auto bits = std::bit_cast<std::uint32_t>(y);
    const int bin =
        (int((bits >> 23) & 0xFF) - 127 + kOctaves / 2) * kSub + int((bits >> 19) & 0xF);
    histogram[std::size_t(std::clamp(bin, 0, kBins - 1))] += omega;
    const std::size_t c = geometry->texel_cell[t];
    const float wc = omega * std::min(1.0f, sw);
    cell_seen[c] += omega;
    w[c] += wc;
    rw[c] += glm::dvec3(wc * r, wc * g, wc * b);
    measured += omega;
  }
  // The q-quantile's bin's upper edge.
  const auto quantile = [&](double q) {
    double below = 0.0;
    for (int b = 0; b < kBins; ++b) {
      below += histogram[std::size_t(b)];
      if (below >= q * measured)
        return std::ldexp(1.0 + (b % kSub + 1) / double(kSub), b / kSub - kOctaves / 2);
    }
    return std::ldexp(1.0, kOctaves / 2);
  };
  std::vector<glm::dvec3> rw_lights = rw;  // before the clip: lights are what lights a floor
  if (fill == Fill::Estimate && options.clip_quantile < 1.0 && measured > 0.0) {
    const auto cap = float(quantile(options.clip_quantile));
    for (std::size_t t = 0; t < texels; ++t) {
      const float y = texel_luminance[t];
      if (!(y > cap)) continue;
      const float sw = m.weight[t];
      const float* p = &m.weighted_radiance[3 * t];
      const float excess = geometry->texel_omega[t] * std::min(1.0f, sw) * (1.0f - cap / y) / sw;
      rw[geometry->texel_cell[t]] -= glm::dvec3(excess * p[0], excess * p[1], excess * p[2]);
    }
  }
  double w_all = 0.0;
  glm::dvec3 rw_all(0.0);
  for (std::size_t c = 0; c < w.size(); ++c) w_all += w[c], rw_all += rw[c];
  any_seen = w_all > 0.0;
  mean = any_seen ? rw_all / w_all : glm::dvec3(0.0);
  residual = ShCoeffs();
  if (fill == Fill::Estimate && any_seen) {
    fit_profile(w, rw, rw_lights);
    if (options.residual_order > 0) fit_residual(w, rw);
  }
  cell_model.resize(geometry->cell_dir.size());
  cell_seen_radiance.resize(geometry->cell_dir.size());
  for (std::size_t c = 0; c < geometry->cell_dir.size(); ++c) {
    cell_model[c] = geometry->cell_total[c] > 0.0 ? model(geometry->cell_dir[c]) : glm::dvec3(0.0);
    cell_seen_radiance[c] = w[c] > 0.0 ? rw_lights[c] / w[c] : glm::dvec3(0.0);
  }
}

// Z at every zone (the elevation profile; dissertation §5.4.1's sky and ground colours, one per
// zone instead of one per hemisphere). A zone counts as seen when at least 0.1 % of it was
// measured, and takes the mean of what was seen of it. Between seen zones Z is linear; beyond
// the outermost seen zone on either side it continues that zone's value, times the trend of
// the log luminance over the last `trend_zones` seen zones, limited to a factor `trend_limit`.
void UnseenEstimator::Impl::fit_profile(const std::vector<double>& w,
                                        const std::vector<glm::dvec3>& rw,
                                        const std::vector<glm::dvec3>& rw_lights) {
  const int zones = grid.zones;
  std::vector<double> zw(std::size_t(zones), 0.0), zt(std::size_t(zones), 0.0);
  std::vector<glm::dvec3> zrw(std::size_t(zones), glm::dvec3(0.0)), zrw_lights = zrw;
  for (std::size_t c = 0; c < w.size(); ++c) {
    const auto z = c / std::size_t(grid.sectors);
    zw[z] += w[c], zrw[z] += rw[c], zrw_lights[z] += rw_lights[c];
    zt[z] += geometry->cell_total[c];
  }
  std::vector<int> seen;
  for (int z = 0; z < zones; ++z)
    if (zone_seen(zw[std::size_t(z)], zt[std::size_t(z)])) seen.push_back(z);
  if (seen.empty()) {
    std::fill(zone_value.begin(), zone_value.end(), mean);
    return;
  }
  const auto value = [&](int z) { return zrw[std::size_t(z)] / zw[std::size_t(z)]; };
  for (int z : seen) zone_value[std::size_t(z)] = value(z);
  for (std::size_t k = 0; k + 1 < seen.size(); ++k)
    for (int z = seen[k] + 1; z < seen[k + 1]; ++z) {
      const double f = double(z - seen[k]) / double(seen[k + 1] - seen[k]);
      zone_value[std::size_t(z)] = (1.0 - f) * value(seen[k]) + f * value(seen[k + 1]);
    }
  // d(log luminance) per zone going outwards from `edge` (step +1 up, -1 down): a weighted
  // least-squares line through the last seen zones, 0 when they are too few to tell.
  const auto trend = [&](int edge, int step) {
    double sw = 0, sx = 0, sy = 0, sxx = 0, sxy = 0;
    for (int k = 0; k < options.trend_zones; ++k) {
      const int z = edge - step * k;
      if (z < 0 || z >= zones || !zone_seen(zw[std::size_t(z)], zt[std::size_t(z)])) break;
      const double wz = zw[std::size_t(z)], x = -double(k);
      const double y = std::log(std::max(luminance(value(z)), 1e-12));
      sw += wz, sx += wz * x, sy += wz * y, sxx += wz * x * x, sxy += wz * x * y;
    }
    const double det = sw * sxx - sx * sx;
    return det > 1e-9 * sw * sw ? (sw * sxy - sx * sy) / det : 0.0;
  };
  const double limit = std::log(options.trend_limit);
  const int top = seen.back(), bottom = seen.front();
  const double up = trend(top, 1), down = trend(bottom, -1);
  for (int z = top + 1; z < zones; ++z)
    zone_value[std::size_t(z)] = value(top) * std::exp(std::clamp(up * (z - top), -limit, limit));
  for (int z = bottom - 1; z >= 0; --z)
    zone_value[std::size_t(z)] =
        value(bottom) * std::exp(std::clamp(down * (bottom - z), -limit, limit));
  if (options.ground_albedo > 0.0 && bottom > 0)
    lean_towards_the_ground(bottom, zw, zt, zrw_lights);
}

// Below the lowest seen zone the profile leans, over a quarter of the y range, towards a
// Lambertian ground lit by the upper hemisphere, L = albedo / pi * E_up: the dissertation's
// lower hemisphere colour (§5.4.1), taken from what lights the floor since the floor itself is
// not seen. E_up sums the upper zones as measured, their lights unclipped, and the profile
// where they are unseen; the lean is scaled by the square of the share of the upper hemisphere
// (cosine-weighted) that was measured, so a ground under an unseen ceiling or sky stays the
// seen zones' continuation.
// A room swept ceiling first then has its floor from its lamps or its sky (bench/RESULTS.md).
void UnseenEstimator::Impl::lean_towards_the_ground(int bottom, const std::vector<double>& zw,
                                                    const std::vector<double>& zt,
                                                    const std::vector<glm::dvec3>& zrw_lights) {
  const int zones = grid.zones;
  const double zone_omega = 4.0 * std::numbers::pi / zones;
  glm::dvec3 e_up(0.0);
  double measured_cos = 0.0, all_cos = 0.0;
  for (int z = zones / 2; z < zones; ++z) {
    const double y = (z + 0.5) * 2.0 / zones - 1.0;  // the zone's centre (equal-area: uniform y)
    const auto zi = std::size_t(z);
    if (!(zt[zi] > 0.0)) continue;  // a small map may leave zones without texels
    double seen = 0.0;
    for (int c = z * grid.sectors; c < (z + 1) * grid.sectors; ++c)
      seen += cell_seen[std::size_t(c)];
    measured_cos += y * seen / zt[zi], all_cos += y;
    e_up += (zone_seen(zw[zi], zt[zi]) ? zrw_lights[zi] / zw[zi] : zone_value[zi]) * y * zone_omega;
  }
  const glm::dvec3 ground = options.ground_albedo / std::numbers::pi * e_up;
  const double ground_luminance = luminance(ground);
  if (!(ground_luminance > 0.0) || !(all_cos > 0.0)) return;
  const double ramp = 0.25 * zones;  // zones in a quarter of the y range (2 / zones each)
  const double share = measured_cos / all_cos;
  for (int z = bottom - 1; z >= 0; --z) {
    const double f = std::min(1.0, (bottom - z) / ramp) * share * share;
    const glm::dvec3 e = zone_value[std::size_t(z)];
    const double le = std::max(luminance(e), 1e-12);
    // Geometric in luminance (the continuation and the ground may be far apart), linear in
    // chromaticity.
    const double l = std::exp((1.0 - f) * std::log(le) + f * std::log(ground_luminance));
    zone_value[std::size_t(z)] = ((1.0 - f) * e / le + f * ground / ground_luminance) * l;
  }
}

// The residual's least squares on the seen cells: (sum w Y Y^T + ridge D) a = sum w Y r with
// D = diag(1 + l(l+1)), per channel.
void UnseenEstimator::Impl::fit_residual(const std::vector<double>& w,
                                         const std::vector<glm::dvec3>& rw) {
  const int order = options.residual_order;
  const int n = sh_count(order);
  cv::Mat a = cv::Mat::zeros(n, n, CV_64F), b = cv::Mat::zeros(n, 3, CV_64F);
  auto basis = std::vector<double>(std::size_t(n));
  for (std::size_t c = 0; c < w.size(); ++c) {
    if (!(w[c] > 0.0)) continue;
    sh_basis_all(order, geometry->cell_dir[c], basis);
    const glm::dvec3 r = rw[c] / w[c] - profile(geometry->cell_dir[c].y);
    for (int i = 0; i < n; ++i) {
      const double wy = w[c] * basis[std::size_t(i)];
      double* row = a.ptr<double>(i);
      for (int j = 0; j < n; ++j) row[j] += wy * basis[std::size_t(j)];
      double* br = b.ptr<double>(i);
      br[0] += wy * r.x, br[1] += wy * r.y, br[2] += wy * r.z;
    }
  }
  for (int l = 0; l < order; ++l)
    for (int mm = -l; mm <= l; ++mm)
      a.at<double>(sh_index(l, mm), sh_index(l, mm)) += options.ridge * (1.0 + l * (l + 1));
  cv::Mat x;
  if (!cv::solve(a, b, x, cv::DECOMP_CHOLESKY)) return;  // cannot happen: A is positive definite
  residual = ShCoeffs(order);
  for (int i = 0; i < n; ++i)
    residual.c[std::size_t(i)] = {x.at<double>(i, 0), x.at<double>(i, 1), x.at<double>(i, 2)};
}

UnseenEstimator::UnseenEstimator(const EnvLayout& layout, Fill fill, FillOptions options)
    : impl_(std::make_unique<Impl>(layout, fill, options)) {}
UnseenEstimator::~UnseenEstimator() = default;
UnseenEstimator::UnseenEstimator(const UnseenEstimator& o)
    : impl_(std::make_unique<Impl>(*o.impl_)) {}
UnseenEstimator& UnseenEstimator::operator=(const UnseenEstimator& o) {
  if (this != &o) impl_ = std::make_unique<Impl>(*o.impl_);
  return *this;
}
UnseenEstimator::UnseenEstimator(UnseenEstimator&&) noexcept = default;
UnseenEstimator& UnseenEstimator::operator=(UnseenEstimator&&) noexcept = default;

void UnseenEstimator::fit(const MeasuredTexels& measured) { impl_->fit(measured); }
Fill UnseenEstimator::fill() const { return impl_->fill; }
const EnvLayout& UnseenEstimator::layout() const { return impl_->layout; }
glm::dvec3 UnseenEstimator::radiance(glm::dvec3 dir) const { return impl_->model(dir); }

double UnseenEstimator::measured_fraction() const {
  return impl_->measured / (4.0 * std::numbers::pi);
}

double UnseenEstimator::estimated_fraction() const {
  if (impl_->fill == Fill::None || !impl_->any_seen) return 0.0;
  return std::max(0.0, 1.0 - measured_fraction());
}

std::shared_ptr<const std::vector<double>> UnseenEstimator::Impl::basis_of_cells(int order) const {
  std::lock_guard lock(geometry->basis_mutex);
  auto& slot = geometry->basis_by_order[order];
  if (!slot) {
    const auto n = std::size_t(sh_count(order));
    auto b = std::make_shared<std::vector<double>>(n * geometry->cell_dir.size());
    for (std::size_t c = 0; c < geometry->cell_dir.size(); ++c)
      if (geometry->cell_total[c] > 0.0)  // a small map may leave cells without texels
        sh_basis_all(order, geometry->cell_dir[c], std::span<double>(b->data() + c * n, n));
    slot = std::move(b);
  }
  return slot;
}

ShCoeffs UnseenEstimator::unseen_sh(int order) const {
  ShCoeffs out(order);
  const Impl& m = *impl_;
  if (m.fill == Fill::None || !m.any_seen) return out;
  const std::shared_ptr<const std::vector<double>> basis = m.basis_of_cells(order);
  const std::size_t n = out.c.size();
  for (std::size_t c = 0; c < m.geometry->cell_total.size(); ++c) {
    const double unseen = m.geometry->cell_total[c] - m.cell_seen[c];
    if (!(unseen > 1e-12)) continue;
    const glm::dvec3 l = unseen * m.cell_model[c];
    const double* y = basis->data() + c * n;
    for (std::size_t k = 0; k < n; ++k) out.c[k] += y[k] * l;
  }
  return out;
}

void UnseenEstimator::remove_from_unseen_sh(ShCoeffs& unseen,
                                            std::span<const std::uint32_t> texels) const {
  const Impl& m = *impl_;
  if (m.fill == Fill::None || !m.any_seen || texels.empty()) return;
  // Solid angle per cell first: a frame's new texels fall in a few dozen cells.
  std::vector<std::pair<std::uint32_t, double>> cells;
  cells.reserve(texels.size());
  for (const std::uint32_t t : texels) {
    if (t >= m.geometry->texel_cell.size())
      throw std::invalid_argument("fill: texel " + std::to_string(t) + " is not in the map");
    if (m.geometry->texel_omega[t] > 0.0f)
      cells.emplace_back(m.geometry->texel_cell[t], m.geometry->texel_omega[t]);
  }
  std::sort(cells.begin(), cells.end());
  const std::shared_ptr<const std::vector<double>> basis = m.basis_of_cells(unseen.order);
  const std::size_t n = unseen.c.size();
  if (basis->size() != n * m.geometry->cell_dir.size())
    throw std::invalid_argument("fill: the SH to update is not of a valid order");
  for (std::size_t i = 0; i < cells.size();) {
    const std::uint32_t c = cells[i].first;
    double omega = 0.0;
    for (; i < cells.size() && cells[i].first == c; ++i) omega += cells[i].second;
    const glm::dvec3 l = omega * m.cell_model[c];
    const double* y = basis->data() + std::size_t(c) * n;
    for (std::size_t k = 0; k < n; ++k) unseen.c[k] -= y[k] * l;
  }
}

EnvMap UnseenEstimator::filled(const MeasuredTexels& m) const {
  const TexelTable& table = *impl_->table;
  if (m.weight.size() != impl_->layout.texel_count() ||
      m.weighted_radiance.size() != 3 * impl_->layout.texel_count())
    throw std::invalid_argument("fill: the measured texels do not fit the map");
  EnvMap env(impl_->layout);
  float* out = env.image.data();
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, table.size(), 4096), [&](const auto& r) {
    for (std::size_t i = r.begin(); i < r.end(); ++i) {
      const std::size_t t = table.index[i];
      const float sw = m.weight[t];
      glm::dvec3 l;
      const float* p = &m.weighted_radiance[3 * t];
      if (sw > 0.0f && std::isfinite(sw))
        l = glm::dvec3(p[0], p[1], p[2]) / double(sw);
      else
        l = impl_->model({table.x[i], table.y[i], table.z[i]});
      out[3 * t] = float(l.x), out[3 * t + 1] = float(l.y), out[3 * t + 2] = float(l.z);
    }
  });
  return env;
}

UnseenEstimator::Cells UnseenEstimator::cells() const {
  const Impl& m = *impl_;
  if (m.fill == Fill::None) return {};
  return {m.grid.zones,          m.grid.sectors,     m.geometry->cell_dir, m.geometry->cell_total,
          m.cell_seen,           m.cell_seen_radiance, m.cell_model};
}

EnvMap fill_black_texels(const EnvMap& env, Fill fill, const FillOptions& options) {
  // The image is its own sum(w L), with w = 1 where it is not black.
  const std::vector<float>& radiance = env.image.storage();
  std::vector<float> weight(env.layout.texel_count());
  for (std::size_t t = 0; t < weight.size(); ++t)
    weight[t] =
        radiance[3 * t] != 0.0f || radiance[3 * t + 1] != 0.0f || radiance[3 * t + 2] != 0.0f
            ? 1.0f
            : 0.0f;
  UnseenEstimator estimator(env.layout, fill, options);
  const MeasuredTexels measured{radiance, weight};
  estimator.fit(measured);
  return estimator.filled(measured);
}

}  // namespace arlight::capture
