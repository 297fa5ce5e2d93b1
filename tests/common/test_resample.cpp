#include <gtest/gtest.h>

#include <cmath>
#include <glm/geometric.hpp>
#include <numbers>

#include "../support/env_fixtures.hpp"
#include "arlight/common/resample.hpp"

using namespace arlight;

namespace {

// Solid-angle-weighted mean of channel 0.
double sphere_mean(const EnvMap& env) {
  const auto t = texel_table(env.layout);
  double s = 0, w = 0;
  for (std::size_t i = 0; i < t->size(); ++i) {
    s += t->solid_angle[i] * env.image.data()[3 * t->index[i]];
    w += t->solid_angle[i];
  }
  return s / w;
}

const Projection kAll[] = {Projection::AngleMap, Projection::LatLong, Projection::Cube};

const glm::dvec3 kLight = glm::normalize(glm::dvec3(0.3, 0.8, -0.5));

// A small bright light (200 within 0.1 rad of kLight) on 1 + a texture of frequencies (fx, fy).
EnvMap light_and_texture(const EnvLayout& layout, double fx, double fy) {
  return test::env_from_function(layout, [&](glm::dvec3 d) {
    const double light = glm::dot(d, kLight) > 0.995 ? 200.0 : 0.0;
    return glm::vec3(float(light + 1.0 + 0.5 * std::sin(fx * d.x) * std::cos(fy * d.y)));
  });
}

}  // namespace

TEST(Resample, ConstantStaysConstantBetweenEveryPair) {
  for (Projection from : kAll)
    for (Projection to : kAll) {
      const EnvLayout src = EnvLayout::for_size(from, 48);
      const EnvMap env =
          test::env_from_function(src, [](glm::dvec3) { return glm::vec3(2, 3, 4); });
      for (int size : {8, 48, 100}) {
        const EnvLayout dst = EnvLayout::for_size(to, size);
        const EnvMap out = resample(env, dst);
        for (int y = 0; y < dst.height(); ++y)
          for (int x = 0; x < dst.width(); ++x) {
            const glm::vec3 v = out.image.at(x, y);
            if (!dst.texel_valid(x, y)) {
              ASSERT_EQ(v, glm::vec3(0)) << "off-sphere texels stay 0";
              continue;
            }
            ASSERT_NEAR(v.x, 2.0f, 1e-5f) << projection_name(from) << "->" << projection_name(to)
                                          << " " << size << " at " << x << "," << y;
            ASSERT_NEAR(v.z, 4.0f, 1e-5f);
          }
      }
    }
}

TEST(Resample, SmoothFunctionsSurviveEveryPair) {
  // f(d) = 1 + d.x + 0.5 d.y - 0.25 d.z, sampled in each projection and resampled to each other.
  auto f = [](glm::dvec3 d) { return glm::vec3(float(1.5 + d.x + 0.5 * d.y - 0.25 * d.z)); };
  for (Projection from : kAll)
    for (Projection to : kAll) {
      const EnvMap env = test::env_from_function(EnvLayout::for_size(from, 128), f);
      const EnvLayout dst = EnvLayout::for_size(to, 32);
      const EnvMap out = resample(env, dst);
      double worst = 0;
      for (int y = 0; y < dst.height(); ++y)
        for (int x = 0; x < dst.width(); ++x) {
          if (!dst.texel_valid(x, y)) continue;
          const glm::dvec2 c = dst.pixel_to_uv({x + 0.5, y + 0.5});
          // Near an angle map's rim every texel is close to the back pole and blurred on purpose.
          if (to == Projection::AngleMap && std::hypot(2 * c.x - 1, 1 - 2 * c.y) > 0.9) continue;
          const glm::dvec3 d = dst.texel_dir(x, y);
          const double e = std::abs(out.image.at(x, y).x - f(d).x);
          // An angle map squeezes the 10 degrees around its back pole (+Z) into its outermost
          // texel ring; there it is only roughly right.
          if (from == Projection::AngleMap && d.z > std::cos(10 * std::numbers::pi / 180)) {
            ASSERT_LT(e, 0.1);
            continue;
          }
          worst = std::max(worst, e);
        }
      // A 128-row lat-long's first texel centres sit 0.7 degrees from the poles; clamped bilinear
      // there is off by that much of the gradient (~0.016 here).
      EXPECT_LT(worst, 0.02) << projection_name(from) << "->" << projection_name(to);
    }
}

TEST(Resample, ShrinkingDoesNotAlias) {
  // One-texel vertical stripes (0/1) on a 1024x512 lat-long. Point sampling into a 16x8 map
  // would give texels of 0 or 1; a correct filter gives the mean 0.5 everywhere.
  const EnvLayout src = EnvLayout::for_size(Projection::LatLong, 512);
  EnvMap env(src);
  for (int y = 0; y < src.height(); ++y)
    for (int x = 0; x < src.width(); ++x) env.image.set(x, y, glm::vec3(float(x % 2)));
  for (Projection to : kAll) {
    const EnvLayout dst = EnvLayout::for_size(to, 8);
    const EnvMap out = resample(env, dst);
    for (int y = 0; y < dst.height(); ++y)
      for (int x = 0; x < dst.width(); ++x) {
        if (!dst.texel_valid(x, y)) continue;
        ASSERT_NEAR(out.image.at(x, y).x, 0.5f, 0.02f)
            << projection_name(to) << " " << x << "," << y;
      }
  }
}

TEST(Resample, PreservesTheMeanRadianceOfADetailedMap) {
  // A small bright light plus texture: the solid-angle-weighted mean (what irradiance sees)
  // must survive shrinking to within 1 %.
  const EnvMap env = light_and_texture(EnvLayout::for_size(Projection::LatLong, 512), 40, 30);
  const double mean = sphere_mean(env);
  for (Projection to : kAll) {
    const EnvMap out = resample(env, EnvLayout::for_size(to, 32));
    EXPECT_NEAR(sphere_mean(out) / mean, 1.0, 0.01) << projection_name(to);
  }
}

TEST(EnvSampler, MipLevelsAverageOverTheSphere) {
  const EnvLayout l = EnvLayout::for_size(Projection::AngleMap, 64);
  EnvMap env =
      test::env_from_function(l, [](glm::dvec3 d) { return glm::vec3(d.y > 0 ? 2.0f : 0.0f); });
  const EnvSampler s(env);
  EXPECT_EQ(s.levels(), 7);  // 64 .. 1
  // The top level is the mean over the sphere: half the sphere at 2 -> 1.
  EXPECT_NEAR(s.sample({0, 0, -1}, s.levels() - 1).x, 1.0f, 1e-4f);
  EXPECT_NEAR(s.sample({0, 1, 0}, 0).x, 2.0f, 1e-6f);
}

TEST(EnvSampler, LatLongWrapsAcrossTheSeam) {
  // Left column 1, right column 3, all else 0: a lookup on the seam (+Z, u = 0) blends the two.
  const EnvLayout l = EnvLayout::for_size(Projection::LatLong, 8);
  EnvMap env(l);
  for (int y = 0; y < l.height(); ++y) {
    env.image.set(0, y, glm::vec3(1));
    env.image.set(l.width() - 1, y, glm::vec3(3));
  }
  EXPECT_NEAR(EnvSampler(env).sample({0, 0, 1}).x, 2.0f, 1e-6f);
}

TEST(EnvSampler, CubeLookupsStayOnTheirFace) {
  // Each face filled with its index: a lookup close to a face edge never blends in a neighbour.
  const EnvLayout l = EnvLayout::for_size(Projection::Cube, 4);
  EnvMap env(l);
  for (int y = 0; y < l.height(); ++y)
    for (int x = 0; x < l.width(); ++x) env.image.set(x, y, glm::vec3(float(y / 4)));
  const EnvSampler s(env);
  EXPECT_EQ(s.sample(glm::normalize(glm::dvec3(1, -0.99, 0.2))).x, 0.0f);  // bottom edge of +X
  EXPECT_EQ(s.sample(glm::normalize(glm::dvec3(0.2, 0.99, 1))).x, 4.0f);
  EXPECT_EQ(s.sample(glm::normalize(glm::dvec3(-0.3, -1, 0.99))).x, 3.0f);
}

TEST(EnvSampler, AngleMapRimDoesNotBleedInTheBlackOutsideTheDisk) {
  const EnvLayout l = EnvLayout::for_size(Projection::AngleMap, 32);
  const EnvMap env = test::env_from_function(l, [](glm::dvec3) { return glm::vec3(5.0f); });
  const EnvSampler s(env);
  for (double a : {0.9, 0.97, 0.995, 1.0})  // angle from -Z as a fraction of pi, up to the rim
    for (int level : {0, 1, 3})
      EXPECT_NEAR(
          s.sample({std::sin(a * std::numbers::pi), 0, -std::cos(a * std::numbers::pi)}, level).x,
          5.0f, 1e-5f)
          << a << " level " << level;
}

// reduce(): a cube map shrunk by a whole factor keeps its power exactly and agrees with
// resample(); other pairs are resampled.
TEST(Reduce, BoxFiltersKeepThePowerAndMatchResample) {
  const EnvMap env = light_and_texture(EnvLayout::for_size(Projection::Cube, 96), 10, 8);
  const EnvLayout small = EnvLayout::for_size(Projection::Cube, 32);
  const EnvMap reduced = reduce(env, small);
  EXPECT_NEAR(sphere_mean(reduced) / sphere_mean(env), 1.0, 1e-6);
  const EnvMap resampled = resample(env, small);
  const auto t = texel_table(small);
  double worst = 0.0;
  for (std::size_t i = 0; i < t->size(); ++i) {
    if (glm::dot(glm::dvec3(t->x[i], t->y[i], t->z[i]), kLight) > 0.99)
      continue;  // the light's rim: each filter spreads it its own way
    const float a = reduced.image.data()[3 * t->index[i]];
    const float b = resampled.image.data()[3 * t->index[i]];
    worst = std::max(worst, std::abs(double(a) - b) / b);
  }
  EXPECT_LT(worst, 0.03);
  // Not a whole factor, or another projection, with at least twice the texels: binned (each
  // texel the mean of the source texels whose centres fall in it), the power within 1 % and
  // the values near resample()'s; finer than the source: resample() itself.
  for (const EnvLayout& other :
       {EnvLayout::for_size(Projection::Cube, 40), EnvLayout::for_size(Projection::AngleMap, 64)}) {
    const EnvMap a = reduce(env, other), b = resample(env, other);
    EXPECT_NEAR(sphere_mean(a) / sphere_mean(env), 1.0, 0.01);
    const auto ot = texel_table(other);
    double far_worst = 0.0;
    for (std::size_t i = 0; i < ot->size(); ++i)
      if (glm::dot(glm::dvec3(ot->x[i], ot->y[i], ot->z[i]), kLight) < 0.99)
        far_worst = std::max(far_worst, std::abs(double(a.image.data()[3 * ot->index[i]]) -
                                                 b.image.data()[3 * ot->index[i]]) /
                                            b.image.data()[3 * ot->index[i]]);
    EXPECT_LT(far_worst, 0.05);
  }
  const EnvLayout finer = EnvLayout::for_size(Projection::AngleMap, 256);
  const EnvMap a = reduce(env, finer), b = resample(env, finer);
  EXPECT_EQ(a.image.data()[3 * finer.texel_count() / 2],
            b.image.data()[3 * finer.texel_count() / 2]);
}
