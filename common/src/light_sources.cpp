#include "arlight/common/light_sources.hpp"

#include <algorithm>
#include <cmath>
#include <glm/geometric.hpp>
#include <numeric>
#include <queue>
#include <stdexcept>

#include "arlight/common/image.hpp"

namespace arlight {

namespace {

struct SourceTexel {
  glm::dvec3 dir;
  glm::dvec3 irradiance;  // L w cos (RGB)
  double energy;          // its luminance
  double solid_angle;
  double radiance;  // luminance of L
};

// A node's cluster from its texels.
LightCluster cluster_of(std::vector<SourceTexel>::const_iterator b,
                        std::vector<SourceTexel>::const_iterator e, glm::dvec3 normal) {
  glm::dvec3 rgb(0.0), moment(0.0);
  double energy = 0, solid_angle = 0;
  for (auto t = b; t != e; ++t) {
    rgb += t->irradiance, moment += t->energy * t->dir;
    energy += t->energy, solid_angle += t->solid_angle;
  }
  const glm::dvec3 centre = glm::length(moment) > 0 ? glm::normalize(moment) : normal;
  double spread = 0;
  for (auto t = b; t != e; ++t)
    spread += t->energy * std::acos(std::clamp(glm::dot(t->dir, centre), -1.0, 1.0));
  LightCluster c;
  c.direction = glm::vec3(centre);
  c.irradiance = glm::vec3(rgb);
  c.solid_angle = float(solid_angle);
  c.spread = energy > 0 ? float(spread / energy) : 0.0f;
  c.texels = int(e - b);
  return c;
}

}  // namespace

int LightTree::leaves() const {
  return int(std::count_if(nodes.begin(), nodes.end(),
                           [](const LightCluster& c) { return c.first_child < 0; }));
}

LightTree build_light_tree(const EnvMap& map, glm::dvec3 normal, const LightTreeOptions& options) {
  if (!(glm::length(normal) > 0))
    throw std::invalid_argument("build_light_tree: the normal is zero");
  if (!(options.power_share > 0 && options.power_share <= 1))
    throw std::invalid_argument("build_light_tree: power_share must be in (0, 1]");
  if (options.max_leaves < 1)
    throw std::invalid_argument("build_light_tree: max_leaves must be >= 1");
  normal = glm::normalize(normal);

  // Every texel above the plane's horizon, with what it gives the plane.
  LightTree tree;
  tree.normal = glm::vec3(normal);
  const auto table = texel_table(map.layout);
  std::vector<SourceTexel> texels;
  glm::dvec3 total(0.0);
  for (std::size_t i = 0; i < table->size(); ++i) {
    const glm::dvec3 d(table->x[i], table->y[i], table->z[i]);
    const double c = glm::dot(d, normal);
    const float* px = map.image.data() + std::size_t(table->index[i]) * 3;
    const glm::dvec3 radiance(px[0], px[1], px[2]);
    if (!(c > 0) || !(luminance(radiance) > 0)) continue;
    const glm::dvec3 e = radiance * (table->solid_angle[i] * c);
    texels.push_back({d, e, luminance(e), table->solid_angle[i], luminance(radiance)});
    total += e;
  }
  tree.receiver_irradiance = glm::vec3(total);
  if (texels.empty()) return tree;

  // The source set: the brightest (by radiance) until they hold power_share of the plane's light.
  std::sort(texels.begin(), texels.end(),
            [](const SourceTexel& a, const SourceTexel& b) { return a.radiance > b.radiance; });
  const double wanted = options.power_share * luminance(total);
  double held = 0;
  std::size_t count = 0;
  while (count < texels.size() && held < wanted) held += texels[count++].energy;
  // A radiance threshold, not a count: texels as bright as the last one taken are taken too
  // (a lamp of one radiance is not cut in two by the order of equal texels).
  while (count < texels.size() && texels[count].radiance >= texels[count - 1].radiance) ++count;
  texels.resize(std::max<std::size_t>(count, 1));

  // Top-down: split the leaf that gives the plane the most light until max_leaves.
  struct Range {
    std::size_t begin, end;
  };
  std::vector<Range> ranges{{0, texels.size()}};
  tree.nodes.push_back(cluster_of(texels.begin(), texels.end(), normal));
  const auto brighter = [&](int a, int b) {
    return luminance(tree.nodes[std::size_t(a)].irradiance) <
           luminance(tree.nodes[std::size_t(b)].irradiance);
  };
  std::priority_queue<int, std::vector<int>, decltype(brighter)> splittable(brighter);
  splittable.push(0);
  int leaves = 1;
  while (leaves < options.max_leaves && !splittable.empty()) {
    const int node = splittable.top();
    splittable.pop();
    const Range r = ranges[std::size_t(node)];
    const auto b = texels.begin() + std::ptrdiff_t(r.begin),
               e = texels.begin() + std::ptrdiff_t(r.end);
    // The widest axis of the cluster's directions, split where half its light is on each side.
    glm::dvec3 lo(2.0), hi(-2.0);
    for (auto t = b; t != e; ++t) lo = glm::min(lo, t->dir), hi = glm::max(hi, t->dir);
    const glm::dvec3 extent = hi - lo;
    const int axis = extent.x >= extent.y && extent.x >= extent.z ? 0
                     : extent.y >= extent.z                       ? 1
                                                                  : 2;
    std::sort(b, e, [axis](const SourceTexel& x, const SourceTexel& y) {
      return x.dir[axis] < y.dir[axis];
    });
    const double half = 0.5 * std::accumulate(b, e, 0.0, [](double s, const SourceTexel& t) {
                          return s + t.energy;
                        });
    double below = 0;
    std::size_t cut = r.begin;
    while (cut + 1 < r.end && below + texels[cut].energy < half) below += texels[cut++].energy;
    cut = std::clamp(cut, r.begin + 1, r.end - 1);

    const int first = int(tree.nodes.size());
    tree.nodes[std::size_t(node)].first_child = first;
    for (const Range child : {Range{r.begin, cut}, Range{cut, r.end}}) {
      ranges.push_back(child);
      tree.nodes.push_back(cluster_of(texels.begin() + std::ptrdiff_t(child.begin),
                                      texels.begin() + std::ptrdiff_t(child.end), normal));
      if (child.end - child.begin > 1) splittable.push(int(tree.nodes.size()) - 1);
    }
    ++leaves;
  }
  return tree;
}

std::vector<int> select_lights(const LightTree& tree, int n) {
  std::vector<int> chosen;
  if (tree.nodes.empty() || n < 1) return chosen;
  chosen.push_back(0);
  const auto light = [&](int i) { return luminance(tree.nodes[std::size_t(i)].irradiance); };
  while (int(chosen.size()) < n) {
    int best = -1;
    for (std::size_t k = 0; k < chosen.size(); ++k)
      if (tree.nodes[std::size_t(chosen[k])].first_child >= 0 &&
          (best < 0 || light(chosen[k]) > light(chosen[std::size_t(best)])))
        best = int(k);
    if (best < 0) break;  // only leaves left
    const int first = tree.nodes[std::size_t(chosen[std::size_t(best)])].first_child;
    chosen[std::size_t(best)] = first;
    chosen.push_back(first + 1);
  }
  std::sort(chosen.begin(), chosen.end(), [&](int a, int b) { return light(a) > light(b); });
  return chosen;
}

namespace {
constexpr float kChannelSpike = 16.0f;
}  // namespace

DominantLight primary_light(const EnvMap& map, const ShCoeffs& sh) {
  const DominantLight broad = sh_dominant_light(sh);
  const glm::dvec3 normal = glm::length(broad.direction) > 0.5f ? glm::dvec3(broad.direction)
                                                                 : glm::dvec3(0, 1, 0);
  // A texel with one channel far above the other two is lossy compression's ringing (park's
  // probe: blue 11800 beside red 40 at the sun), not a light: limited to kChannelSpike x the
  // larger of the other two before the lights are looked for.
  EnvMap limited = map;
  float* px = limited.image.data();
  for (std::size_t i = 0; i < limited.image.texel_count(); ++i, px += 3)
    for (int c = 0; c < 3; ++c)
      px[c] = std::min(px[c], kChannelSpike * std::max(px[(c + 1) % 3], px[(c + 2) % 3]));
  const LightTree tree = build_light_tree(limited, normal);
  const std::vector<int> clusters = select_lights(tree, kPrimaryClusters);
  if (clusters.empty()) return {};
  // The median cut splits a bright lamp itself: the brightest cluster and those near it are the
  // light, their illuminance summed, their direction the luminance-weighted mean.
  const glm::vec3 first = tree.nodes[std::size_t(clusters.front())].direction;
  glm::dvec3 sum_dir(0.0), colour(0.0);
  for (const int k : clusters) {
    const LightCluster& c = tree.nodes[std::size_t(k)];
    if (glm::dot(c.direction, first) < std::cos(kPrimaryMergeRadians)) continue;
    const double cosine = std::max(0.05, glm::dot(normal, glm::dvec3(c.direction)));
    colour += glm::dvec3(c.irradiance) / cosine;
    sum_dir += luminance(glm::dvec3(c.irradiance)) / cosine * glm::dvec3(c.direction);
  }
  const double len = glm::length(sum_dir);
  return {len > 0.0 ? glm::vec3(sum_dir / len) : first, glm::vec3(colour)};
}

}  // namespace arlight
