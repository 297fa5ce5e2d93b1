// The room's small, bright lights split from its environment for the specular part
// (specular_lights.hpp, issue 51 §1): the lights and the residual sum to the map, a round lamp
// is found where it is with its power and size, two lamps apart are two lights, a wide bright
// region stays in the residual, options out of range are refused.
#include <gtest/gtest.h>

#include <cmath>
#include <glm/geometric.hpp>
#include <numbers>
#include <stdexcept>

#include "../support/env_fixtures.hpp"
#include "arlight/common/image.hpp"
#include "arlight/common/specular_lights.hpp"

using namespace arlight;

namespace {

constexpr double kPi = std::numbers::pi;

double angle_deg(glm::dvec3 a, glm::dvec3 b) {
  return std::acos(std::clamp(glm::dot(glm::normalize(a), glm::normalize(b)), -1.0, 1.0)) * 180.0 / kPi;
}

struct Lamp {
  glm::dvec3 dir;
  double radiance;
  double radius_deg = 3.0;
};

// A dim, slightly blue room (a floor darker than the ceiling) with round lamps.
EnvMap room(const std::vector<Lamp>& lamps, Projection projection = Projection::LatLong) {
  const EnvLayout layout = EnvLayout::for_size(projection, projection == Projection::Cube ? 64 : 256);
  return test::env_from_function(layout, [&](glm::dvec3 d) {
    glm::dvec3 l = glm::dvec3(0.2, 0.25, 0.3) * (1.0 + 0.5 * d.y);
    for (const Lamp& lamp : lamps)
      if (glm::dot(d, glm::normalize(lamp.dir)) > std::cos(lamp.radius_deg * kPi / 180.0))
        l += glm::dvec3(1.0, 0.9, 0.7) * lamp.radiance;
    return glm::vec3(l);
  });
}

// Sum of radiance x solid angle over the map (RGB).
glm::dvec3 power_of(const EnvMap& map) {
  const TexelTable& t = *texel_table(map.layout);
  glm::dvec3 sum(0.0);
  for (std::size_t i = 0; i < t.size(); ++i) {
    const float* p = map.image.data() + 3 * std::size_t(t.index[i]);
    sum += glm::dvec3(p[0], p[1], p[2]) * t.solid_angle[i];
  }
  return sum;
}

}  // namespace

TEST(SpecularLights, TheLightsAndTheResidualSumToTheMap) {
  for (Projection projection : {Projection::LatLong, Projection::Cube}) {
    const EnvMap map = room({{{0.3, 1.0, 0.2}, 500.0}, {{-1.0, 0.2, 0.5}, 300.0, 5.0}}, projection);
    const SpecularSplit split = split_specular_lights(map);
    ASSERT_EQ(split.lights.size(), 2u);
    glm::dvec3 sum = power_of(split.residual);
    for (const SpecularLight& l : split.lights) sum += glm::dvec3(l.power);
    const glm::dvec3 want = power_of(map);
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(sum[c], want[c], 1e-5 * want[c]);
    // Nowhere brighter than the map, nowhere negative; unchanged away from the lamps.
    const float* a = map.image.data();
    const float* b = split.residual.image.data();
    for (std::size_t i = 0; i < 3 * map.image.texel_count(); ++i) {
      EXPECT_LE(b[i], a[i] * (1 + 1e-6f));
      EXPECT_GE(b[i], 0.0f);
    }
    const TexelTable& t = *texel_table(map.layout);
    for (std::size_t i = 0; i < t.size(); ++i)
      if (t.y[i] < -0.5) {
        const std::size_t k = 3 * std::size_t(t.index[i]);
        ASSERT_EQ(a[k], b[k]);
      }
  }
}

TEST(SpecularLights, ARoundLampIsFoundWithItsPowerAndSize) {
  const glm::dvec3 dir = glm::normalize(glm::dvec3(0.4, 1.0, -0.3));
  const double radius = 4.0, radiance = 400.0;
  const EnvMap map = room({{dir, radiance, radius}});
  const SpecularSplit split = split_specular_lights(map);
  ASSERT_EQ(split.lights.size(), 1u);
  const SpecularLight& l = split.lights[0];
  EXPECT_LT(angle_deg(glm::dvec3(l.direction), dir), 0.3);
  // The lamp's power less what the residual keeps under it (the mean).
  const double solid_angle = 2.0 * kPi * (1.0 - std::cos(radius * kPi / 180.0));
  EXPECT_NEAR(l.power.x / (radiance * solid_angle), 1.0, 0.12);
  EXPECT_NEAR(l.radius * 180.0 / kPi, radius, 0.25 * radius);
  EXPECT_NEAR(l.power.z / l.power.x, 0.7, 0.05);  // the lamp's colour, not the room's
}

TEST(SpecularLights, TwoLampsApartAreTwoLightsAndAWideGlowStaysInTheResidual) {
  const glm::dvec3 a = glm::normalize(glm::dvec3(1.0, 1.0, 0.0)), b = glm::normalize(glm::dvec3(-1.0, 1.0, 0.2));
  const SpecularSplit two = split_specular_lights(room({{a, 400.0}, {b, 200.0}}));
  ASSERT_EQ(two.lights.size(), 2u);
  EXPECT_LT(angle_deg(glm::dvec3(two.lights[0].direction), a), 0.5);  // brightest first
  EXPECT_LT(angle_deg(glm::dvec3(two.lights[1].direction), b), 0.5);
  // A bright patch 50 degrees across is not a small light: it is left to the chain.
  const EnvMap glow = room({{{0.0, 1.0, 0.0}, 400.0, 25.0}});
  const SpecularSplit wide = split_specular_lights(glow, {.threshold = 8.0});
  EXPECT_TRUE(wide.lights.empty());
  EXPECT_EQ(power_of(wide.residual), power_of(glow));
  // None asked for, or a room with no light well above its mean: no lights, the map itself.
  EXPECT_TRUE(split_specular_lights(room({{a, 300.0}}), {.max_lights = 0}).lights.empty());
  EXPECT_TRUE(split_specular_lights(room({})).lights.empty());
}

TEST(SpecularLights, OptionsOutOfRangeAreRefused) {
  const EnvMap map = room({});
  EXPECT_THROW(split_specular_lights(map, {.threshold = 1.0}), std::invalid_argument);
  EXPECT_THROW(split_specular_lights(map, {.threshold = NAN}), std::invalid_argument);
  EXPECT_THROW(split_specular_lights(map, {.threshold = 8.0, .floor = 9.0}), std::invalid_argument);
  EXPECT_THROW(split_specular_lights(map, {.floor = 0.0}), std::invalid_argument);
  EXPECT_THROW(split_specular_lights(map, {.max_lights = -1}), std::invalid_argument);
  EXPECT_THROW(split_specular_lights(map, {.max_lights = kMaxSpecularLights + 1}), std::invalid_argument);
  EXPECT_THROW(split_specular_lights(map, {.max_radius = 0.0}), std::invalid_argument);
  EXPECT_THROW(split_specular_lights(map, {.max_radius = 2.0}), std::invalid_argument);
}
