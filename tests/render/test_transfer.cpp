// Radiance transfer baked with Embree (transfer.hpp) against analytic occlusion.
#include <gtest/gtest.h>

#include <cmath>
#include <glm/geometric.hpp>
#include <numbers>
#include <stdexcept>
#include <vector>

#include "arlight/common/sh.hpp"
#include "arlight/render/transfer.hpp"

using namespace arlight;

namespace {

constexpr double kPi = std::numbers::pi;

struct TriangleMesh {
  std::vector<glm::vec3> positions;
  std::vector<std::uint32_t> indices;
};

// A UV sphere finely enough tessellated that its inscribed polyhedron is within 0.05 % of the
// radius (the error the tolerances below allow for).
TriangleMesh sphere(glm::vec3 centre, float radius, int rings = 96, int segments = 192) {
  TriangleMesh m;
  for (int i = 0; i <= rings; ++i) {
    const double theta = kPi * i / rings;
    for (int j = 0; j <= segments; ++j) {
      const double phi = 2.0 * kPi * j / segments;
      m.positions.push_back(
          centre + radius * glm::vec3(glm::dvec3(std::sin(theta) * std::cos(phi), std::cos(theta),
                                                 std::sin(theta) * std::sin(phi))));
    }
  }
  const auto at = [&](int i, int j) { return std::uint32_t(i * (segments + 1) + j); };
  for (int i = 0; i < rings; ++i)
    for (int j = 0; j < segments; ++j)
      m.indices.insert(m.indices.end(), {at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j),
                                         at(i + 1, j + 1), at(i, j + 1)});
  return m;
}

ShCoeffs constant_room(double radiance) {
  ShCoeffs l(3);
  l.c[0] = glm::dvec3(radiance * 2.0 * std::sqrt(kPi));  // integral of Y00 over the sphere
  return l;
}

}  // namespace

// The form factor of a sphere (radius r, centre at distance D, at angle theta from the normal,
// wholly above the horizon) seen from a point of a plane is sin^2(alpha) cos(theta) with
// sin(alpha) = r / D: the point's ambient occlusion is 1 - r^2 h / D^3 for a centre h above the
// plane. The bake matches it where the sphere touches the plane, floats above it, and to the side.
TEST(Transfer, ASphereOverAPlaneOccludesWhatTheFormFactorSays) {
  const float r = 0.5f;
  for (const float h : {0.5f, 1.0f, 2.0f}) {
    const TriangleMesh ball = sphere({0.0f, h, 0.0f}, r);
    const Occluder occluder(ball.positions, ball.indices);
    std::vector<glm::vec3> points, normals;
    for (const float x : {0.0f, 0.3f, 0.8f, 2.0f}) {
      points.push_back({x, 0.0f, 0.0f});
      normals.push_back({0.0f, 1.0f, 0.0f});
    }
    const Transfer t = bake_transfer(occluder, points, normals, {.directions = 16384, .order = 3});
    ASSERT_EQ(t.size(), points.size());
    for (std::size_t i = 0; i < points.size(); ++i) {
      const double d2 = double(points[i].x) * points[i].x + double(h) * h;
      const double expected = 1.0 - double(r) * r * h / (d2 * std::sqrt(d2));
      EXPECT_NEAR(t.ao[i], expected, 0.006) << "h " << h << " x " << points[i].x;
      // The bent normal leans away from the ball (towards +x) wherever the ball is to one side.
      if (points[i].x > 0.2f) {
        EXPECT_GT(t.bent_normal[i].x, 0.01f);
      } else {
        EXPECT_NEAR(t.bent_normal[i].x, 0.0f, 0.01f);
      }
    }
    // Under the ball's centre the loss is largest: 1 - r^2 / h^2.
    EXPECT_LT(t.ao[0], t.ao[1]);
  }
}

// The ray-traced shadow reference over every texel of a map: a uniform sky gives the form
// factor; a single lamp gives 0 or 1 as the ball hides it or not; the scene frame is the map's
// turned (scene z up = world y up).
TEST(ShadowReference, UniformSkyGivesTheFormFactorAndALampItsVisibility) {
  const float r = 0.5f, h = 1.2f;
  const TriangleMesh ball = sphere({0.0f, 0.0f, h}, r);  // scene frame: z up
  const Occluder occluder(ball.positions, ball.indices);
  const glm::dmat3 scene_from_world(glm::dvec3(1, 0, 0), glm::dvec3(0, 0, 1), glm::dvec3(0, -1, 0));
  const EnvLayout layout = EnvLayout::for_size(Projection::LatLong, 256);
  EnvMap sky(layout);
  for (int y = 0; y < layout.height(); ++y)
    for (int x = 0; x < layout.width(); ++x) sky.image.set(x, y, glm::vec3(2.0f));
  const ShadowReference uniform(sky, scene_from_world, {0, 0, 1});
  std::vector<glm::dvec3> points;
  for (const double x : {0.0, 0.4, 1.0, 3.0}) points.push_back({x, 0.0, 0.0});
  const std::vector<double> ratios = uniform.ratios(occluder, points);
  for (std::size_t i = 0; i < points.size(); ++i) {
    const double d2 = points[i].x * points[i].x + double(h) * h;
    EXPECT_NEAR(ratios[i], 1.0 - double(r) * r * h / (d2 * std::sqrt(d2)), 0.005) << points[i].x;
  }
  // One lamp texel straight above (world +y): the ball hides it from under its centre only.
  EnvMap lamp(layout);
  const glm::ivec2 t = layout.dir_to_texel({0.0, 1.0, 0.0});
  lamp.image.set(t.x, t.y, glm::vec3(100.0f));
  const ShadowReference one(lamp, scene_from_world, {0, 0, 1});
  EXPECT_EQ(one.ratio(occluder, {0.0, 0.0, 0.0}), 0.0);
  EXPECT_EQ(one.ratio(occluder, {0.7, 0.0, 0.0}), 1.0);
  // Per channel (the reference renders' coloured shadows): the same red lamp overhead beside a
  // dim blue sky. Under the ball red is gone and blue keeps the form factor's share; the
  // luminance ratio is the channels' weighted by the light each brings.
  EnvMap coloured(layout);
  for (int y = 0; y < layout.height(); ++y)
    for (int x = 0; x < layout.width(); ++x) coloured.image.set(x, y, glm::vec3(0.0f, 0.0f, 0.5f));
  coloured.image.set(t.x, t.y, glm::vec3(100.0f, 0.0f, 0.5f));
  const ShadowReference rgb(coloured, scene_from_world, {0, 0, 1});
  const glm::dvec3 under = rgb.ratio_rgb(occluder, {0.0, 0.0, 0.0});
  EXPECT_EQ(under.r, 0.0);
  EXPECT_EQ(under.g, 1.0);  // no green light at all: nothing to lose
  EXPECT_NEAR(under.b, 1.0 - double(r) * r / (double(h) * h), 0.005);
  EXPECT_GT(rgb.ratio(occluder, {0.0, 0.0, 0.0}), 0.0);
  EXPECT_LT(rgb.ratio(occluder, {0.0, 0.0, 0.0}), under.b);
}

// In a room of constant radiance the transfer dotted with the room's SH is exactly the ambient
// occlusion (the lobe-averaged radiance the point still receives).
TEST(Transfer, ConstantRoomGivesTheAmbientOcclusion) {
  const TriangleMesh ball = sphere({0.0f, 1.0f, 0.0f}, 0.5f, 32, 64);
  const Occluder occluder(ball.positions, ball.indices);
  const std::vector<glm::vec3> points{{0.0f, 0.0f, 0.0f}, {0.6f, 0.0f, 0.2f}, {3.0f, 0.0f, 0.0f}};
  const std::vector<glm::vec3> normals(points.size(), glm::vec3(0.0f, 1.0f, 0.0f));
  const Transfer t = bake_transfer(occluder, points, normals);
  for (std::size_t i = 0; i < points.size(); ++i)
    EXPECT_NEAR(t.apply(i, constant_room(2.5)).x, 2.5 * t.ao[i], 1e-4) << i;
  EXPECT_LT(t.ao[0], 0.8f);
  EXPECT_GT(t.ao[2], 0.98f);
}

// Where nothing is in the way (the outside of a convex ball), the transfer is the clamped-cosine
// lobe of the irradiance map: dotted with any SH-9 lighting it gives the irradiance-map value
// (thesis Alg. 4.6's zonal convolution at s = 1) along the normal, and the bent normal is the
// normal.
TEST(Transfer, AnUnoccludedPointGetsTheIrradianceMapsValue) {
  const TriangleMesh ball = sphere({0.0f, 0.0f, 0.0f}, 1.0f, 48, 96);
  const Occluder occluder(ball.positions, ball.indices);
  std::vector<glm::vec3> points, normals;
  for (const glm::vec3 n : {glm::vec3(0, 1, 0), glm::normalize(glm::vec3(1, -0.3f, 0.4f)),
                            glm::normalize(glm::vec3(-0.2f, 0.1f, -1))}) {
    points.push_back(n * 1.001f);
    normals.push_back(n);
  }
  const Transfer t = bake_transfer(occluder, points, normals, {.directions = 8192, .order = 3});
  ShCoeffs lighting(3);
  const double values[9] = {3.0, 0.8, -1.2, 0.5, 0.3, -0.2, 0.4, 0.1, -0.35};
  for (int k = 0; k < 9; ++k)
    lighting.c[std::size_t(k)] = glm::dvec3(values[k], 0.5 * values[k], 1.0);
  const ShCoeffs irradiance = sh_convolve(lighting, phong_zonal_all(3, 1.0));
  for (std::size_t i = 0; i < points.size(); ++i) {
    EXPECT_NEAR(t.ao[i], 1.0f, 2e-3f) << i;
    EXPECT_GT(glm::dot(t.bent_normal[i], normals[i]), 0.9999f) << i;
    const glm::dvec3 got = t.apply(i, lighting), want = sh_evaluate(irradiance, normals[i]);
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(got[c], want[c], 5e-3 * (1.0 + std::abs(want[c]))) << i;
  }
}

// A point inside a closed mesh sees nothing: no light, and its bent normal falls back to the
// normal.
TEST(Transfer, APointInsideAClosedMeshReceivesNothing) {
  const TriangleMesh ball = sphere({0.0f, 0.0f, 0.0f}, 1.0f, 16, 32);
  const Occluder occluder(ball.positions, ball.indices);
  const std::vector<glm::vec3> points{{0.0f, 0.0f, 0.0f}}, normals{{0.0f, 0.0f, 1.0f}};
  const Transfer t = bake_transfer(occluder, points, normals);
  EXPECT_EQ(t.ao[0], 0.0f);
  EXPECT_EQ(t.bent_normal[0], normals[0]);
  EXPECT_EQ(t.apply(0, constant_room(1.0)).x, 0.0);
}

TEST(Transfer, BadMeshesAndOptionsAreRefusedWithWhatIsWrong) {
  const std::vector<glm::vec3> positions{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  try {
    const std::vector<std::uint32_t> bad{0, 1, 3};
    Occluder o(positions, bad);
    FAIL() << "an index out of range was taken";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("out of range"), std::string::npos) << e.what();
  }
  EXPECT_THROW(Occluder(positions, std::vector<std::uint32_t>{0, 1}), std::invalid_argument);
  const Occluder ok(positions, std::vector<std::uint32_t>{0, 1, 2});
  const std::vector<glm::vec3> one{{0, 0, 1}};
  EXPECT_THROW(bake_transfer(ok, one, std::vector<glm::vec3>{}), std::invalid_argument);
  EXPECT_THROW(bake_transfer(ok, one, one, {.directions = 4}), std::invalid_argument);
}
