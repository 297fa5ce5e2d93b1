// The shadow-casting light sources of an environment map (light_sources.hpp): the tutorial §6
// source set, its median-cut KD-tree and the §6.4 run-time choice of clusters.
#include <gtest/gtest.h>

#include <cmath>
#include <glm/geometric.hpp>
#include <numbers>
#include <numeric>
#include <stdexcept>

#include "../support/env_fixtures.hpp"
#include "arlight/common/image.hpp"
#include "arlight/common/light_sources.hpp"

using namespace arlight;

namespace {

constexpr double kPi = std::numbers::pi;
const glm::dvec3 kUp(0, 1, 0);

double angle_deg(glm::dvec3 a, glm::dvec3 b) {
  return std::acos(std::clamp(glm::dot(glm::normalize(a), glm::normalize(b)), -1.0, 1.0)) * 180.0 /
         kPi;
}

// A dim grey room with round lamps of `radiance` and angular radius `radius_deg`.
struct Lamp {
  glm::dvec3 dir;
  double radiance;
};
EnvMap room(const std::vector<Lamp>& lamps, double radius_deg = 4.0, double ambient = 0.05) {
  const EnvLayout layout = EnvLayout::for_size(Projection::LatLong, 128);
  const double cos_r = std::cos(radius_deg * kPi / 180.0);
  return test::env_from_function(layout, [&](glm::dvec3 d) {
    double l = ambient;
    for (const Lamp& lamp : lamps)
      if (glm::dot(d, glm::normalize(lamp.dir)) > cos_r) l += lamp.radiance;
    return glm::vec3(float(l));
  });
}

// What the texels within `radius_deg` of `dir` give the plane: sum L w cos.
double irradiance_near(const EnvMap& map, glm::dvec3 dir, double radius_deg) {
  double e = 0;
  const double cos_r = std::cos(radius_deg * kPi / 180.0);
  for (int y = 0; y < map.layout.height(); ++y)
    for (int x = 0; x < map.layout.width(); ++x) {
      const glm::dvec3 d = map.layout.texel_dir(x, y);
      if (glm::dot(d, glm::normalize(dir)) > cos_r && d.y > 0)
        e += luminance(glm::dvec3(map.image.at(x, y))) * map.layout.texel_solid_angle(x, y) * d.y;
    }
  return e;
}

}  // namespace

TEST(LightTree, TheSourceSetIsTheBrightestSeventyPercent) {
  // A constant sky gives the plane pi times its radiance, all of it one radiance: all sources.
  const LightTree constant = build_light_tree(room({}, 4.0, 2.0), kUp);
  EXPECT_NEAR(constant.receiver_irradiance.g, 2.0 * kPi, 2.0 * kPi * 0.005);
  EXPECT_NEAR(constant.nodes[0].irradiance.g, constant.receiver_irradiance.g, 1e-3);
  // A sky brighter towards the zenith: the top 70 % of its light (within the last row of
  // texels taken), split into 32 clusters, all nearer the zenith than the rest.
  const EnvMap sky = test::env_from_function(
      EnvLayout::for_size(Projection::LatLong, 128),
      [](glm::dvec3 d) { return glm::vec3(float(1.0 + 3.0 * std::max(d.y, 0.0))); });
  const LightTree tree = build_light_tree(sky, kUp);
  const double root = luminance(glm::dvec3(tree.nodes[0].irradiance));
  const double total = luminance(glm::dvec3(tree.receiver_irradiance));
  EXPECT_GE(root, 0.7 * total - 1e-4);
  EXPECT_LE(root, 0.72 * total);
  EXPECT_EQ(tree.leaves(), 32);
  EXPECT_EQ(tree.nodes.size(), 63u);
  EXPECT_LT(angle_deg(tree.nodes[0].direction, kUp), 1.0);
}

// Median cut splits at the power median: two lamps that give the plane as much light each are
// the root's two halves (all of the light in the set: nothing else in the room).
TEST(LightTree, TwoLampsAreTheFirstSplitAndHoldWhatTheyGiveThePlane) {
  const glm::dvec3 a = glm::normalize(glm::dvec3(0.6, 1.0, 0.2)),
                   b = glm::normalize(glm::dvec3(-0.2, 1.0, -0.6));
  const EnvMap map = room({{a, 300.0}, {b, 300.0}}, 4.0, 0.0);
  const LightTree tree = build_light_tree(map, kUp, {1.0, 32});
  const std::vector<int> two = select_lights(tree, 2);
  ASSERT_EQ(two.size(), 2u);
  // As bright as each other: either may come first.
  const bool a_first = angle_deg(tree.nodes[std::size_t(two[0])].direction, a) < 10.0;
  const LightCluster& first = tree.nodes[std::size_t(two[a_first ? 0 : 1])];
  const LightCluster& second = tree.nodes[std::size_t(two[a_first ? 1 : 0])];
  EXPECT_LT(angle_deg(first.direction, a), 0.5);
  EXPECT_LT(angle_deg(second.direction, b), 0.5);
  EXPECT_NEAR(luminance(glm::dvec3(first.irradiance)), irradiance_near(map, a, 4.5),
              0.01 * irradiance_near(map, a, 4.5));
  EXPECT_NEAR(luminance(glm::dvec3(second.irradiance)), irradiance_near(map, b, 4.5),
              0.01 * irradiance_near(map, b, 4.5));
  EXPECT_LT(first.spread, float(4.0 * kPi / 180.0));
}

TEST(LightTree, ALampUnderTheHorizonCastsNothingOnThePlane) {
  const glm::dvec3 above = glm::normalize(glm::dvec3(0.3, 1.0, 0.0)), below(0.0, -1.0, 0.0);
  const LightTree tree = build_light_tree(room({{above, 100.0}, {below, 1000.0}}), kUp);
  for (const LightCluster& c : tree.nodes) EXPECT_GT(glm::dot(glm::dvec3(c.direction), kUp), 0.0);
  EXPECT_LT(angle_deg(tree.nodes[0].direction, above), 1.0);
}

TEST(LightTree, AnyNumberOfClustersHoldsTheWholeSourceSet) {
  const EnvMap map =
      room({{glm::dvec3(0.6, 1.0, 0.2), 300.0}, {glm::dvec3(-0.2, 0.3, 1.0), 50.0}}, 15.0, 0.5);
  const LightTree tree = build_light_tree(map, kUp, {0.7, 16});
  EXPECT_EQ(tree.leaves(), 16);
  for (const LightCluster& c : tree.nodes) {
    if (c.first_child < 0) continue;
    const glm::vec3 sum = tree.nodes[std::size_t(c.first_child)].irradiance +
                          tree.nodes[std::size_t(c.first_child) + 1].irradiance;
    EXPECT_NEAR(sum.r, c.irradiance.r, 1e-4f * c.irradiance.r);
    EXPECT_EQ(tree.nodes[std::size_t(c.first_child)].texels +
                  tree.nodes[std::size_t(c.first_child) + 1].texels,
              c.texels);
  }
  const double root = luminance(glm::dvec3(tree.nodes[0].irradiance));
  for (int n = 1; n <= 20; ++n) {
    const std::vector<int> chosen = select_lights(tree, n);
    EXPECT_EQ(int(chosen.size()), std::min(n, 16));
    double sum = 0;
    for (std::size_t k = 0; k < chosen.size(); ++k) {
      sum += luminance(glm::dvec3(tree.nodes[std::size_t(chosen[k])].irradiance));
      if (k > 0) {
        EXPECT_GE(luminance(tree.nodes[std::size_t(chosen[k - 1])].irradiance),
                  luminance(tree.nodes[std::size_t(chosen[k])].irradiance));
      }
    }
    EXPECT_NEAR(sum, root, 1e-4 * root) << n << " clusters";
  }
  // Median cut: the root's halves hold half its light each (within the texel at the cut).
  const double left = luminance(glm::dvec3(tree.nodes[1].irradiance));
  EXPECT_NEAR(left / root, 0.5, 0.05);
}

TEST(LightTree, BlackSkyHasNoSourcesAndBadOptionsAreNamed) {
  const LightTree black = build_light_tree(room({}, 4.0, 0.0), kUp);
  EXPECT_TRUE(black.nodes.empty());
  EXPECT_TRUE(select_lights(black, 4).empty());
  const EnvMap map = room({});
  EXPECT_THROW(build_light_tree(map, glm::dvec3(0.0)), std::invalid_argument);
  EXPECT_THROW(build_light_tree(map, kUp, {0.0, 8}), std::invalid_argument);
  EXPECT_THROW(build_light_tree(map, kUp, {0.7, 0}), std::invalid_argument);
}

// light.json's primary light (issue 34 §4): the brightest cluster, wherever it is — a lamp low
// beside the horizon or below it is found as well as one above — with its illuminance at normal
// incidence (the lamp's radiance x solid angle), and the brighter of two lamps wins.
TEST(PrimaryLight, IsTheBrightestLampWhereverItIsWithItsIlluminance) {
  const double radius = 6.0, radiance = 200.0;
  const double lamp_power = radiance * 2 * kPi * (1 - std::cos(radius * kPi / 180.0));
  for (const glm::dvec3 dir : {glm::dvec3(0.3, 0.9, -0.2), glm::dvec3(-0.8, 0.1, 0.5),
                               glm::dvec3(0.2, -0.7, 0.6)}) {
    const EnvMap map = room({{dir, radiance}}, radius);
    const DominantLight p = primary_light(map, sh_project(map, 3));
    EXPECT_LT(angle_deg(glm::dvec3(p.direction), dir), 2.0) << dir.x << " " << dir.y;
    EXPECT_NEAR(p.colour.g, lamp_power, 0.15 * lamp_power) << dir.x << " " << dir.y;
  }
  const glm::dvec3 bright(-0.5, 0.6, -0.6), dim(0.7, 0.5, 0.4);
  const EnvMap two = room({{bright, radiance}, {dim, radiance / 3}}, radius);
  EXPECT_LT(angle_deg(glm::dvec3(primary_light(two, sh_project(two, 3)).direction), bright), 2.0);
  const EnvMap black = room({}, radius, 0.0);
  EXPECT_EQ(primary_light(black, sh_project(black, 3)).colour, glm::vec3(0.0f));
}
