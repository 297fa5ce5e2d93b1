#include "registration.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <glm/gtc/quaternion.hpp>
#include <numbers>
#include <vector>

#include "arlight/common/image.hpp"
#include "arlight/common/projection.hpp"

namespace arlight::capture {

namespace {

// Coarse peaks refined finely: the best and the runners-up it must beat.
constexpr int kPeaks = 4;

// A sample or texel counts when it is measured about as well as a well-exposed pixel's half
// (the capture's kWellMeasured).
constexpr float kWell = 0.5f;

// A frame sample: its ray in the device's own world frame and its log luminance.
struct Sample {
  glm::dvec3 dir;
  double log_luminance;
};

// Blocks of `block` x `block` pixels of the frame whose mean weight is well measured.
std::vector<Sample> frame_samples(const LinearFrame& f, const PinholeCamera& camera,
                                  const glm::dquat& sensor, int block) {
  std::vector<Sample> out;
  const glm::dmat3 to_world = glm::mat3_cast(sensor);
  for (int by = 0; by + block <= f.height; by += block)
    for (int bx = 0; bx + block <= f.width; bx += block) {
      double w = 0.0, r = 0.0, g = 0.0, b = 0.0;
      for (int y = by; y < by + block; ++y)
        for (int x = bx; x < bx + block; ++x) {
          const std::size_t p = std::size_t(y) * std::size_t(f.width) + std::size_t(x);
          w += f.weight[p];
          r += f.weighted_radiance[3 * p], g += f.weighted_radiance[3 * p + 1],
              b += f.weighted_radiance[3 * p + 2];
        }
      if (w < kWell * block * block) continue;
      const double l = luminance(float(r / w), float(g / w), float(b / w));
      if (!(l > 0.0)) continue;
      const glm::dvec2 centre(bx + 0.5 * (block - 1), by + 0.5 * (block - 1));
      out.push_back({to_world * camera.unproject(centre), std::log(l)});
    }
  return out;
}

// The map's log luminance per texel of `layout` where it is measured (NaN elsewhere): the
// solid-angle-weighted mean of the map's well-measured texels in it, where they cover at least
// three quarters of it.
std::vector<double> map_log_luminance(const MapAccumulators& map, const EnvLayout& layout) {
  const TexelTable& table = *texel_table(map.layout);
  const bool same = layout == map.layout;
  std::vector<double> all(layout.texel_count(), 0.0), seen(all.size(), 0.0), sum(all.size(), 0.0);
  for (std::size_t i = 0; i < table.size(); ++i) {
    const std::size_t t = table.index[i];
    std::size_t c = t;
    if (!same) {
      const glm::ivec2 p = layout.dir_to_texel({table.x[i], table.y[i], table.z[i]});
      c = std::size_t(p.y) * std::size_t(layout.width()) + std::size_t(p.x);
    }
    all[c] += table.solid_angle[i];
    const float w = map.weight[t];
    if (w < kWell) continue;
    const float* acc = &map.weighted_radiance[3 * t];
    seen[c] += table.solid_angle[i];
    sum[c] += table.solid_angle[i] * luminance(acc[0] / w, acc[1] / w, acc[2] / w);
  }
  std::vector<double> out(all.size(), std::numeric_limits<double>::quiet_NaN());
  for (std::size_t c = 0; c < out.size(); ++c)
    if (all[c] > 0.0 && seen[c] >= 0.75 * all[c] && sum[c] > 0.0)
      out[c] = std::log(sum[c] / seen[c]);
  return out;
}

// Correlation of paired log luminances (the frame's x, the map's y) less what both owe to
// elevation e (the direction's y): a room's light falls from ceiling to floor at every heading
// alike, so that part would fit any heading. The partial correlation given e, from sums.
struct Correlation {
  double sx = 0, sy = 0, se = 0, sxx = 0, syy = 0, see = 0, sxy = 0, sxe = 0, sye = 0;
  int n = 0;
  void add(double x, double y, double e) {
    sx += x, sy += y, se += e, sxx += x * x, syy += y * y, see += e * e;
    sxy += x * y, sxe += x * e, sye += y * e;
    ++n;
  }
  // -1 when there are too few pairs or either side, less its elevation trend, is too flat to
  // tell headings apart (standard deviation below min_contrast).
  double score(int min_pairs, double min_contrast) const {
    if (n < std::max(min_pairs, 3)) return -1.0;
    const double mx = sx / n, my = sy / n, me = se / n;
    const double vx = sxx / n - mx * mx, vy = syy / n - my * my, ve = see / n - me * me;
    const double cxy = sxy / n - mx * my, cxe = sxe / n - mx * me, cye = sye / n - my * me;
    // Residuals of x and y after their least-squares lines in e.
    const double k = ve > 1e-12 ? 1.0 / ve : 0.0;
    const double rx = vx - cxe * cxe * k, ry = vy - cye * cye * k, rxy = cxy - cxe * cye * k;
    const double c = min_contrast * min_contrast;
    if (!(rx >= c) || !(ry >= c)) return -1.0;
    return rxy / std::sqrt(rx * ry);
  }
};

// The samples rotated by `heading` against the map's log luminance in `layout`.
Correlation correlate(const std::vector<Sample>& samples, double heading,
                      const std::vector<double>& map, const EnvLayout& layout) {
  const double c = std::cos(heading), s = std::sin(heading);
  Correlation k;
  for (const Sample& m : samples) {
    // R_y(heading) * dir: +Z turns towards +X.
    const glm::dvec3 d(c * m.dir.x + s * m.dir.z, m.dir.y, -s * m.dir.x + c * m.dir.z);
    const glm::ivec2 p = layout.dir_to_texel(d);
    const double y = map[std::size_t(p.y) * std::size_t(layout.width()) + std::size_t(p.x)];
    if (!std::isnan(y)) k.add(m.log_luminance, y, d.y);
  }
  return k;
}

double circular_distance(double a, double b) {
  const double d = std::fmod(std::abs(a - b), 2.0 * std::numbers::pi);
  return std::min(d, 2.0 * std::numbers::pi - d);
}

std::string text(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.2f", v);
  return buf;
}

}  // namespace

glm::dquat heading_rotation(double heading) {
  return glm::angleAxis(heading, glm::dvec3(0.0, 1.0, 0.0));
}

HeadingFit fit_heading(const LinearFrame& frame, const PinholeCamera& camera,
                       const glm::dquat& sensor, const MapAccumulators& map,
                       const RegistrationOptions& o) {
  HeadingFit fit;
  // Coarse: blocks of about the coarse grid's texel, every heading.
  const EnvLayout coarse = EnvLayout::for_size(Projection::Cube, o.coarse_face);
  const double coarse_texel = 0.5 * std::numbers::pi / o.coarse_face;
  const double pixel = 1.0 / camera.intrinsics().fx;
  const int block = std::max(1, int(std::lround(coarse_texel / pixel)));
  const std::vector<Sample> blocks = frame_samples(frame, camera, sensor, block);
  if (int(blocks.size()) < o.min_blocks) {
    fit.why = "the view has " + std::to_string(blocks.size()) + " well-exposed blocks (needs " +
              std::to_string(o.min_blocks) + ")";
    return fit;
  }
  const std::vector<double> coarse_map = map_log_luminance(map, coarse);
  const int min_pairs =
      std::max(o.min_blocks, int(std::ceil(o.min_overlap * double(blocks.size()))));
  const int steps = std::max(1, int(std::lround(360.0 / o.coarse_step_deg)));
  std::vector<double> score(std::size_t(steps), -1.0);
  int best = -1;
  for (int i = 0; i < steps; ++i) {
    score[std::size_t(i)] = correlate(blocks, 2.0 * std::numbers::pi * i / steps, coarse_map, coarse)
                                .score(min_pairs, o.min_contrast);
    if (score[std::size_t(i)] > -1.0 && (best < 0 || score[std::size_t(i)] > score[std::size_t(best)]))
      best = i;
  }
  if (best < 0) {
    fit.why = "no heading lays " + std::to_string(int(o.min_overlap * 100)) +
              " % of the view on textured parts of the map";
    return fit;
  }
  // The coarse peaks, best first, each more than distinct_deg from every better one.
  std::vector<int> order(std::size_t(steps), 0);
  for (int i = 0; i < steps; ++i) order[std::size_t(i)] = i;
  std::sort(order.begin(), order.end(),
            [&](int a, int b) { return score[std::size_t(a)] > score[std::size_t(b)]; });
  std::vector<int> peaks;
  for (int i : order) {
    if (score[std::size_t(i)] <= -1.0 || int(peaks.size()) == kPeaks) break;
    const double h = 2.0 * std::numbers::pi * i / steps;
    if (std::all_of(peaks.begin(), peaks.end(), [&](int p) {
          return circular_distance(h, 2.0 * std::numbers::pi * p / steps) >
                 glm::radians(o.distinct_deg);
        }))
      peaks.push_back(i);
  }

  // Fine: every pixel against the map's own texels, around each peak; the best is the fit, the
  // best of the others its runner-up (the coarse grid blurs a tree into its neighbour, the
  // pixels do not).
  const std::vector<Sample> pixels = frame_samples(frame, camera, sensor, 1);
  const std::vector<double> fine_map = map_log_luminance(map, map.layout);
  const int fine_pairs = int(std::ceil(o.min_overlap * double(pixels.size())));
  const int half = int(std::lround(o.fine_span_deg / o.fine_step_deg));
  for (int p : peaks) {
    double peak_score = -1.0, peak_heading = 0.0, peak_overlap = 0.0;
    for (int i = -half; i <= half; ++i) {
      const double h = 2.0 * std::numbers::pi * p / steps + glm::radians(i * o.fine_step_deg);
      const Correlation k = correlate(pixels, h, fine_map, map.layout);
      const double sc = k.score(fine_pairs, o.min_contrast);
      if (sc > peak_score)
        peak_score = sc, peak_heading = h, peak_overlap = double(k.n) / double(pixels.size());
    }
    if (peak_score > fit.score) {
      fit.runner_up = std::max(fit.runner_up, fit.score);
      fit.score = peak_score, fit.heading = peak_heading, fit.overlap = peak_overlap;
    } else {
      fit.runner_up = std::max(fit.runner_up, peak_score);
    }
  }
  fit.heading = std::remainder(fit.heading, 2.0 * std::numbers::pi);
  if (fit.score < o.min_score) {
    fit.why = "the best heading explains the view with a correlation of " + text(fit.score) +
              " (needs " + text(o.min_score) + ")";
    return fit;
  }
  if (fit.score - fit.runner_up < o.min_margin) {
    fit.why = "a heading over " + std::to_string(int(o.distinct_deg)) +
              " degrees from the best fits almost as well (correlation " + text(fit.score) +
              " against " + text(fit.runner_up) + ")";
    return fit;
  }
  fit.ok = true;
  return fit;
}

}  // namespace arlight::capture
