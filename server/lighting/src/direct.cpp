// Methods `accurate` (thesis Alg. 4.1) and `bounded` (§6.2.2 with bounds derived from the lobe).
#include "direct.hpp"

#include <chrono>
#include <cmath>
#include <glm/geometric.hpp>
#include <numbers>

#include "job.hpp"
#include "kernels.hpp"

namespace arlight::lighting::detail {

double bounded_cos_threshold(double s) {
  // Dropping every point where f = c^s < T loses at most T * sum(L w) = T 4pi Lmean of the
  // numerator, while the denominator is ~2pi/(s+1); so the value changes by at most
  // 2 T (s+1) Lmean. Eqs. 6.1/6.2 divide by (a + eps) with eps = 1e-4 x the map's mean (~Lmean):
  // T = 1e-3 * 1e-4 / (2 (s+1)) keeps that below 0.1 % even where the map is black.
  constexpr double kTolerance = 1e-3 * 1e-4;
  const double t = kTolerance / (2.0 * (s + 1.0));
  return std::exp(std::log(t) / s);
}

double auto_cos_threshold(double s) {
  // As bounded_cos_threshold, with the cut's change bounded by 1e-4 of the environment's mean
  // radiance instead of 0.1 % of eq. 6.1's epsilon (1e-7 of it): 1 % of a texel 100x darker
  // than the mean, under auto's 0.5 % target where values are not that dark. Measured: no error
  // figure of the bundled probes moved by 0.01 %; the s = 1280 window is 9.3 deg, not 11.1.
  constexpr double kTolerance = 1e-4;
  const double t = kTolerance / (2.0 * (s + 1.0));
  return std::exp(std::log(t) / s);
}

double exact_cos_threshold(double s) {
  // Below this cosine c^s < 1e-30 of the lobe's peak. Every sum holds the peak's neighbourhood
  // (c^s ~ 1, weight ~ one texel) and radiance spans far less than 1e14 between texels, so such
  // terms are below double precision's 1e-16 of the result: skipping them changes nothing.
  return std::exp(-69.0 / s);
}

void integrate_direct(const PointCells& pts, const glm::dvec3* dirs, const PowerChain& chain,
                      std::span<const double> min_cos, double* acc) {
  const int n = chain.size();
  const std::size_t stride = 4 * std::size_t(kLaneWidth) * std::size_t(n);
  std::vector<double> lanes(kQueries * stride, 0.0);
  // Visit the cells within reach of the directions' bounding cone, then test each cell
  // against every direction.
  glm::dvec3 centre(0.0);
  for (int q = 0; q < kQueries; ++q) centre += dirs[q];
  centre = glm::length(centre) > 1e-12 ? glm::normalize(centre) : dirs[0];
  double radius = 0.0;
  for (int q = 0; q < kQueries; ++q)
    radius = std::max(radius, std::acos(std::clamp(glm::dot(dirs[q], centre), -1.0, 1.0)));
  const double reach = std::acos(std::clamp(min_cos[0], -1.0, 1.0)) + radius + 1e-9;
  pts.for_cells_within(centre, reach >= std::numbers::pi ? -2.0 : std::cos(reach),
                       [&](const PointCells::Cell& cell) {
                         double c = 0.0;
                         for (int q = 0; q < kQueries; ++q)
                           c = std::max(c, PointCells::max_cos(cell, dirs[q]));
                         int maps = n;
                         while (maps > 0 && c <= min_cos[std::size_t(maps - 1)]) --maps;
                         if (maps > 0)
                           accumulate_chain(pts, cell.begin, cell.end, dirs, chain, maps,
                                            lanes.data());
                       });
  for (int q = 0; q < kQueries; ++q) reduce_lanes(lanes.data() + q * stride, n, acc + 4 * n * q);
}

Cone bounding_cone(std::span<const glm::dvec3> dirs) {
  glm::dvec3 sum(0.0);
  for (const glm::dvec3& d : dirs) sum += d;
  if (glm::dot(sum, sum) < 1e-24) return {glm::dvec3(0, 0, 1), std::numbers::pi};
  const glm::dvec3 centre = glm::normalize(sum);
  double min_cos = 1.0;
  for (const glm::dvec3& d : dirs) min_cos = std::min(min_cos, glm::dot(centre, d));
  return {centre, std::acos(std::clamp(min_cos, -1.0, 1.0)) + 1e-9};
}

void BatchIntegrator::run(std::span<const glm::dvec3> dirs, double* acc) {
  if (dirs.empty()) return;
  const Cone batch = bounding_cone(dirs);
  const double reach = window_ + batch.radius;
  const double min_cos = reach >= std::numbers::pi ? -2.0 : std::cos(reach);
  const int n = chain_.size();
  if (n == 1 && pts_.has_float()) {
    // Single precision, one lobe: the cells within reach of the batch are listed once; each
    // group of kQueries neighbours then sums, in place, the listed cells within its own
    // smaller cone's reach (consecutive cells as one run).
    candidates_.clear();
    pts_.for_cells_within(batch.centre, min_cos,
                          [&](const PointCells::Cell& cell) { candidates_.push_back(&cell); });
    for (std::size_t first = 0; first < dirs.size(); first += kQueries) {
      glm::dvec3 group[kQueries];
      for (int q = 0; q < kQueries; ++q) group[q] = dirs[std::min(dirs.size() - 1, first + q)];
      const Cone cone = bounding_cone(group);
      // A cell is needed when its centre lies within reach + its radius r of the group's:
      // cos(angle) > cos(reach + r) = cos(reach) cos(r) - sin(reach) sin(r), padded for rounding.
      const double group_reach = window_ + cone.radius;
      const double cos_reach = std::cos(group_reach), sin_reach = std::sin(group_reach);
      const bool everything = group_reach >= std::numbers::pi;
      double sums[4 * kQueries] = {};
      double above[12] = {};  // cell_sums of the cells above every horizon of the group
      const double sin_rho = std::sin(cone.radius), cos_rho = std::cos(cone.radius);
      std::uint32_t run_begin = 0, run_end = 0;
      for (const PointCells::Cell* cell : candidates_) {
        const double d = glm::dot(cone.centre, cell->centre);
        if (!everything && d < cos_reach * cell->cos_r - sin_reach * cell->sin_r - 1e-9) continue;
        if (linear_) {
          // Every point of the cell within 90 deg of every direction of the group: angle
          // between centres + the cell's radius + the group's < 90 deg, i.e. d > sin(r + rho).
          const double sin_sum = cell->sin_r * cos_rho + cell->cos_r * sin_rho;
          if (cone.radius + std::acos(cell->cos_r) < 0.5 * std::numbers::pi &&
              d > sin_sum + 1e-9) {
            const double* m = &pts_.cell_sums[12 * std::size_t(cell - pts_.cells.data())];
            for (int k = 0; k < 12; ++k) above[k] += m[k];
            continue;
          }
        }
        if (cell->begin != run_end) {
          if (run_end > run_begin)
            accumulate_single_f32(pts_, run_begin, run_end, group, chain_, sums);
          run_begin = cell->begin;
        }
        run_end = cell->end;
      }
      if (run_end > run_begin) accumulate_single_f32(pts_, run_begin, run_end, group, chain_, sums);
      if (linear_)
        for (int q = 0; q < kQueries; ++q)
          for (int k = 0; k < 4; ++k)
            sums[4 * q + k] += group[q].x * above[3 * k] + group[q].y * above[3 * k + 1] +
                               group[q].z * above[3 * k + 2];
      for (std::size_t q = 0; q < kQueries && first + q < dirs.size(); ++q)
        std::copy_n(sums + 4 * q, 4, acc + (first + q) * 4);
    }
    return;
  }
  gather_cells(pts_, batch.centre, min_cos, gathered_);
  const std::size_t stride = 4 * std::size_t(kLaneWidth) * std::size_t(n);
  lanes_.resize(kQueries * stride);
  for (std::size_t first = 0; first < dirs.size(); first += kQueries) {
    glm::dvec3 group[kQueries];
    for (int q = 0; q < kQueries; ++q) group[q] = dirs[std::min(dirs.size() - 1, first + q)];
    std::fill(lanes_.begin(), lanes_.end(), 0.0);
    accumulate_chain(gathered_, 0, std::uint32_t(gathered_.size()), group, chain_, n,
                     lanes_.data());
    for (std::size_t q = 0; q < kQueries && first + q < dirs.size(); ++q)
      reduce_lanes(lanes_.data() + q * stride, n, acc + (first + q) * 4 * std::size_t(n));
  }
}

ComputedMapSet run_direct(const Job& job, bool bounded) {
  const auto t0 = std::chrono::steady_clock::now();
  // Whole-hemisphere sums: big cells keep the per-cell work small next to the sums.
  const PointCells pts = points_from_texels(job.input, bounded ? 64 : 256);
  const std::vector<int> order = ascending_order(job.shininess);
  const int n = int(order.size());
  std::vector<double> sorted, min_cos;
  for (int k : order) {
    const double s = job.shininess[std::size_t(k)];
    sorted.push_back(s);
    min_cos.push_back(bounded ? bounded_cos_threshold(s) : exact_cos_threshold(s));
  }
  // The lowest threshold decides which cells are visited at all (thresholds rise with s).
  for (int k = n - 2; k >= 0; --k)
    min_cos[std::size_t(k)] = std::min(min_cos[std::size_t(k)], min_cos[std::size_t(k + 1)]);
  const PowerChain chain(sorted);
  std::vector<EnvMap> maps = blank_maps(job);
  for_each_tile(job.output.tiles(), job.progress, [&](const Tile& tile) {
    // Texels in groups of kQueries (neighbours along a row share their cells).
    const auto [dirs, pixels] = job.output.collect(tile);
    std::vector<double> acc(kQueries * 4 * std::size_t(n));
    for (std::size_t first = 0; first < dirs.size(); first += kQueries) {
      glm::dvec3 group[kQueries];
      for (int q = 0; q < kQueries; ++q) group[q] = dirs[std::min(dirs.size() - 1, first + q)];
      integrate_direct(pts, group, chain, min_cos, acc.data());
      for (std::size_t q = 0; q < kQueries && first + q < dirs.size(); ++q)
        for (int k = 0; k < n; ++k) {
          const double* a = acc.data() + 4 * (q * std::size_t(n) + std::size_t(k));
          float* out =
              maps[std::size_t(order[std::size_t(k)])].image.data() + 3 * pixels[first + q];
          for (int c = 0; c < 3; ++c) out[c] = a[3] > 0.0 ? float(a[c] / a[3]) : 0.0f;
        }
    }
    for (int k = 0; k < n; ++k) job.progress.tile_done(order[std::size_t(k)], tile);
  });
  return joint_result(std::move(maps), t0,
                      std::vector<std::string>(
                          std::size_t(n), bounded ? "bounded: lobe window where cos^s >= 5e-8/(s+1)"
                                                  : "accurate: every input texel"));
}

}  // namespace arlight::lighting::detail
