#include "arlight/common/specular_lights.hpp"

#include <algorithm>
#include <cmath>
#include <glm/geometric.hpp>
#include <numbers>
#include <stdexcept>
#include <string>

#include "arlight/common/image.hpp"

namespace arlight {

namespace {

struct ExcessTexel {
  glm::dvec3 dir;
  glm::dvec3 power;  // excess radiance x solid angle
  double energy;     // luminance of power
  double solid_angle;
  std::uint32_t index;  // the texel's y * width + x
};

using Iter = std::vector<ExcessTexel>::iterator;

struct Cluster {
  std::size_t begin = 0, end = 0;
  SpecularLight light;
  double energy = 0;
  bool compact = false;
};

Cluster cluster_of(std::vector<ExcessTexel>& texels, std::size_t begin, std::size_t end) {
  glm::dvec3 power(0.0), moment(0.0);
  double energy = 0, solid_angle = 0;
  for (std::size_t i = begin; i < end; ++i) {
    const ExcessTexel& t = texels[i];
    power += t.power, moment += t.energy * t.dir;
    energy += t.energy, solid_angle += t.solid_angle;
  }
  const glm::dvec3 centre = glm::normalize(moment);
  // Second moment of the angle from the centre, each texel a disc of its own solid angle
  // (a small disc of radius rho has mean squared angle rho^2 / 2).
  double second = 0;
  for (std::size_t i = begin; i < end; ++i) {
    const ExcessTexel& t = texels[i];
    const double a = std::acos(std::clamp(glm::dot(t.dir, centre), -1.0, 1.0));
    second += t.energy * (a * a + t.solid_angle / (2.0 * std::numbers::pi));
  }
  Cluster c;
  c.begin = begin, c.end = end, c.energy = energy;
  c.light.direction = glm::vec3(centre);
  c.light.power = glm::vec3(power);
  c.light.radius = float(std::sqrt(2.0 * second / energy));
  // A uniform disc's moment radius is its area radius; two lamps apart, or a long tube, have
  // a moment radius far above the radius of the area their texels cover.
  const double area_radius = std::acos(std::clamp(1.0 - solid_angle / (2.0 * std::numbers::pi), -1.0, 1.0));
  c.compact = c.light.radius <= 1.5 * area_radius;
  return c;
}

// Splits a cluster at the middle of its directions' widest extent (a k-d split): two lamps apart
// fall on either side, where the median cut's power median would cut the brighter in two.
std::pair<Cluster, Cluster> split(std::vector<ExcessTexel>& texels, const Cluster& c) {
  const Iter b = texels.begin() + std::ptrdiff_t(c.begin), e = texels.begin() + std::ptrdiff_t(c.end);
  glm::dvec3 lo(2.0), hi(-2.0);
  for (Iter t = b; t != e; ++t) lo = glm::min(lo, t->dir), hi = glm::max(hi, t->dir);
  const glm::dvec3 extent = hi - lo;
  const int axis = extent.x >= extent.y && extent.x >= extent.z ? 0 : extent.y >= extent.z ? 1 : 2;
  const double middle = 0.5 * (lo[axis] + hi[axis]);
  const Iter cut = std::partition(b, e, [&](const ExcessTexel& t) { return t.dir[axis] < middle; });
  const std::size_t at = std::clamp(std::size_t(cut - texels.begin()), c.begin + 1, c.end - 1);
  return {cluster_of(texels, c.begin, at), cluster_of(texels, at, c.end)};
}

}  // namespace

SpecularSplit split_specular_lights(const EnvMap& map, const SpecularSplitOptions& options) {
  if (!(options.threshold > 1.0) || !std::isfinite(options.threshold))
    throw std::invalid_argument("split_specular_lights: threshold must be a finite number above 1");
  if (!(options.floor > 0.0 && options.floor <= options.threshold))
    throw std::invalid_argument("split_specular_lights: floor must be in (0, threshold]");
  if (options.max_lights < 0 || options.max_lights > kMaxSpecularLights)
    throw std::invalid_argument("split_specular_lights: max_lights must be in [0, " +
                                std::to_string(kMaxSpecularLights) + "]");
  if (!(options.max_radius > 0.0 && options.max_radius <= 0.5 * std::numbers::pi))
    throw std::invalid_argument("split_specular_lights: max_radius must be in (0, pi/2]");

  SpecularSplit out{{}, map};
  const TexelTable& table = *texel_table(map.layout);
  const float* px = map.image.data();
  double weighted = 0, total_solid_angle = 0;
  for (std::size_t i = 0; i < table.size(); ++i) {
    const float* p = px + 3 * std::size_t(table.index[i]);
    weighted += table.solid_angle[i] * double(luminance(p[0], p[1], p[2]));
    total_solid_angle += table.solid_angle[i];
  }
  const double mean = weighted / total_solid_angle;
  const double limit = options.threshold * mean, floor = options.floor * mean;
  if (options.max_lights == 0 || !(limit > 0.0)) return out;

  std::vector<ExcessTexel> texels;
  for (std::size_t i = 0; i < table.size(); ++i) {
    const float* p = px + 3 * std::size_t(table.index[i]);
    const double lum = luminance(double(p[0]), double(p[1]), double(p[2]));
    if (!(lum > limit)) continue;
    const glm::dvec3 excess = glm::dvec3(p[0], p[1], p[2]) * (1.0 - floor / lum);
    const glm::dvec3 power = excess * table.solid_angle[i];
    texels.push_back({glm::dvec3(table.x[i], table.y[i], table.z[i]), power, luminance(power),
                      table.solid_angle[i], table.index[i]});
  }
  if (texels.empty()) return out;

  // Top-down: split the brightest cluster that is not compact until max_lights clusters.
  std::vector<Cluster> leaves{cluster_of(texels, 0, texels.size())};
  while (int(leaves.size()) < options.max_lights) {
    auto brightest = leaves.end();
    for (auto c = leaves.begin(); c != leaves.end(); ++c)
      if (!c->compact && c->end - c->begin > 1 &&
          (brightest == leaves.end() || c->energy > brightest->energy))
        brightest = c;
    if (brightest == leaves.end()) break;
    auto [a, b] = split(texels, *brightest);
    *brightest = a;
    leaves.push_back(b);
  }

  // Compact clusters no wider than max_radius are the lights; the residual keeps the floor's
  // luminance (the texel's colour) where they were.
  float* res = out.residual.image.data();
  for (const Cluster& c : leaves) {
    if (!c.compact || c.light.radius > options.max_radius) continue;
    out.lights.push_back(c.light);
    for (std::size_t i = c.begin; i < c.end; ++i) {
      float* p = res + 3 * std::size_t(texels[i].index);
      const double keep = floor / luminance(double(p[0]), double(p[1]), double(p[2]));
      for (int ch = 0; ch < 3; ++ch) p[ch] = float(double(p[ch]) * keep);
    }
  }
  std::sort(out.lights.begin(), out.lights.end(), [](const SpecularLight& x, const SpecularLight& y) {
    return luminance(x.power) > luminance(y.power);
  });
  return out;
}

}  // namespace arlight
