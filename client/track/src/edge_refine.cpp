#include "edge_refine.hpp"

#include <algorithm>
#include <cmath>
#include <opencv2/calib3d.hpp>
#include <vector>

namespace arlight::track::detail {

namespace {

// 8-bit code -> linear intensity (IEC 61966-2-1 sRGB decoding, or the identity).
const std::array<float, 256>& decode_table(bool srgb) {
  static const std::array<float, 256> lin = [] {
    std::array<float, 256> t{};
    for (int i = 0; i < 256; ++i) {
      const double c = i / 255.0;
      t[std::size_t(i)] =
          float(c <= 0.04045 ? c / 12.92 : std::pow((c + 0.055) / 1.055, 2.4));
    }
    return t;
  }();
  static const std::array<float, 256> id = [] {
    std::array<float, 256> t{};
    for (int i = 0; i < 256; ++i) t[std::size_t(i)] = float(i / 255.0);
    return t;
  }();
  return srgb ? lin : id;
}

// Bilinear sample of the linear image at pixel coordinates (integer = pixel centre).
struct Sampler {
  const cv::Mat& gray;
  const std::array<float, 256>& lut;
  std::optional<float> at(cv::Point2d p) const {
    const double x0 = std::floor(p.x), y0 = std::floor(p.y);
    const int x = int(x0), y = int(y0);
    if (x < 0 || y < 0 || x + 1 >= gray.cols || y + 1 >= gray.rows) return std::nullopt;
    const double fx = p.x - x0, fy = p.y - y0;
    const std::uint8_t* r0 = gray.ptr<std::uint8_t>(y) + x;
    const std::uint8_t* r1 = gray.ptr<std::uint8_t>(y + 1) + x;
    return float((1 - fy) * ((1 - fx) * lut[r0[0]] + fx * lut[r0[1]]) +
                 fy * ((1 - fx) * lut[r1[0]] + fx * lut[r1[1]]));
  }
};

// A line a x + b y = c (a^2 + b^2 = 1) through points by total least squares.
struct Line {
  double a = 0, b = 0, c = 0;
};

std::optional<Line> fit_line(const std::vector<cv::Point2d>& pts) {
  if (pts.size() < 4) return std::nullopt;
  cv::Point2d mean(0, 0);
  for (const auto& p : pts) mean += p;
  mean *= 1.0 / double(pts.size());
  double sxx = 0, sxy = 0, syy = 0;
  for (const auto& p : pts) {
    const cv::Point2d d = p - mean;
    sxx += d.x * d.x, sxy += d.x * d.y, syy += d.y * d.y;
  }
  // The normal is the eigenvector of the scatter matrix with the smaller eigenvalue.
  const double theta = 0.5 * std::atan2(2 * sxy, sxx - syy);  // direction of the line
  Line l;
  l.a = -std::sin(theta);
  l.b = std::cos(theta);
  l.c = l.a * mean.x + l.b * mean.y;
  return l;
}

std::optional<cv::Point2d> intersect(const Line& p, const Line& q) {
  const double det = p.a * q.b - p.b * q.a;
  if (std::abs(det) < 1e-9) return std::nullopt;
  return cv::Point2d((p.c * q.b - p.b * q.c) / det, (p.a * q.c - p.c * q.a) / det);
}

// Ideal pinhole pixels -> the image's (distorted) pixels.
std::array<cv::Point2d, 4> distort(const std::array<cv::Point2d, 4>& ideal,
                                   const EdgeRefineParams& prm) {
  std::vector<cv::Point3d> rays;
  for (const auto& p : ideal)
    rays.emplace_back((p.x - prm.k(0, 2)) / prm.k(0, 0), (p.y - prm.k(1, 2)) / prm.k(1, 1), 1.0);
  std::vector<cv::Point2d> px;
  cv::projectPoints(rays, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), prm.k, prm.dist, px);
  return {px[0], px[1], px[2], px[3]};
}

// One pass: edge crossings around the current corners, lines, intersections.
std::optional<RefinedCorners> pass(const Sampler& s, const std::array<cv::Point2d, 4>& c,
                                   const EdgeRefineParams& prm, double search) {
  const cv::Point2d centre = 0.25 * (c[0] + c[1] + c[2] + c[3]);
  std::array<Line, 4> lines;
  int total = 0;
  for (int e = 0; e < 4; ++e) {
    const cv::Point2d a = c[std::size_t(e)], b = c[std::size_t((e + 1) % 4)];
    const double len = cv::norm(b - a);
    if (len < 12) return std::nullopt;  // too small to refine
    const cv::Point2d d = (b - a) * (1.0 / len);
    cv::Point2d n(-d.y, d.x);
    if (n.dot(0.5 * (a + b) - centre) < 0) n = -n;  // outwards, towards the white quiet zone
    // Across the edge: the black border inside and the quiet zone outside are one module
    // (a sixth of the marker) wide; stay within most of it on both sides.
    const cv::Point2d opp = 0.5 * (c[std::size_t((e + 2) % 4)] + c[std::size_t((e + 3) % 4)]);
    const double module = std::abs((0.5 * (a + b) - opp).dot(n)) / 6.0;
    const double reach = std::min(search, 0.8 * module);
    if (reach < 1.5) return std::nullopt;
    const double step = 0.25;
    const int half = int(std::floor(reach / step));
    std::vector<cv::Point2d> pts;
    std::vector<float> prof(std::size_t(2 * half + 1));
    for (double t = 0.12 * len; t <= 0.88 * len; t += 1.0) {
      const cv::Point2d base = a + d * t;
      bool ok = true;
      for (int i = -half; i <= half && ok; ++i) {
        const auto v = s.at(base + n * (i * step));
        if (!v) ok = false;
        else prof[std::size_t(i + half)] = *v;
      }
      if (!ok) continue;
      // Black and white levels at the ends of the profile; the crossing of their mean.
      const float lo = std::min(prof[0], prof[1]), hi = std::max(prof.end()[-1], prof.end()[-2]);
      if (!(hi > 2.5f * lo + 0.02f)) continue;  // no clean dark-to-bright edge here
      const float mid = 0.5f * (lo + hi);
      int cross = -1, crossings = 0;
      for (std::size_t i = 0; i + 1 < prof.size(); ++i)
        if ((prof[i] < mid) != (prof[i + 1] < mid)) ++crossings, cross = int(i);
      if (crossings != 1 || prof[std::size_t(cross)] >= mid) continue;  // noisy or reversed
      const double f = (mid - prof[std::size_t(cross)]) /
                       (prof[std::size_t(cross) + 1] - prof[std::size_t(cross)]);
      pts.push_back(base + n * ((cross - half + f) * step));
    }
    if (pts.size() < std::max<std::size_t>(6, std::size_t(0.3 * len))) return std::nullopt;
    // Edges are straight in the ideal pinhole image: undistort before fitting.
    std::vector<cv::Point2d> ideal;
    cv::undistortPoints(pts, ideal, prm.k, prm.dist, cv::noArray(), prm.k);
    auto line = fit_line(ideal);
    if (!line) return std::nullopt;
    // One round of trimming: drop points far from the line (a JPEG block, a bit of glare).
    std::vector<cv::Point2d> kept;
    for (const auto& p : ideal)
      if (std::abs(line->a * p.x + line->b * p.y - line->c) < 0.5) kept.push_back(p);
    if (kept.size() < ideal.size() / 2) return std::nullopt;
    line = fit_line(kept);
    if (!line) return std::nullopt;
    lines[std::size_t(e)] = *line;
    total += int(kept.size());
  }
  RefinedCorners out;
  for (int k = 0; k < 4; ++k) {
    // Corner k joins edge k-1 (from corner k-1 to k) and edge k (from k to k+1).
    const auto p = intersect(lines[std::size_t((k + 3) % 4)], lines[std::size_t(k)]);
    if (!p) return std::nullopt;
    out.undistorted[std::size_t(k)] = *p;
  }
  out.distorted = distort(out.undistorted, prm);
  out.edge_points = total;
  return out;
}

}  // namespace

std::optional<RefinedCorners> refine_corners(const cv::Mat& gray,
                                             const std::array<cv::Point2d, 4>& corners,
                                             const EdgeRefineParams& prm) {
  const Sampler s{gray, decode_table(prm.srgb)};
  // A wide pass from the detector's corners, then a narrow one from the refined ones.
  auto first = pass(s, corners, prm, prm.search_px);
  if (!first) return std::nullopt;
  auto second = pass(s, first->distorted, prm, 2.0);
  if (!second) return first;
  // The lines may move a poorly detected corner by a few pixels, not by a fair part of the
  // marker: that would be a line locked onto something else.
  double side = 0;
  for (int k = 0; k < 4; ++k) side += 0.25 * cv::norm(corners[std::size_t((k + 1) % 4)] - corners[std::size_t(k)]);
  for (int k = 0; k < 4; ++k)
    if (cv::norm(second->distorted[std::size_t(k)] - corners[std::size_t(k)]) >
        std::max(prm.search_px + 1.0, 0.15 * side))
      return std::nullopt;
  return second;
}

}  // namespace arlight::track::detail
