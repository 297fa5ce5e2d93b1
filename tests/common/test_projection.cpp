// Pins every rule of common/CONVENTIONS.md.
#include <gtest/gtest.h>

#include <cmath>
#include <glm/geometric.hpp>
#include <numbers>

#include "arlight/common/projection.hpp"

using namespace arlight;

namespace {

constexpr double kPi = std::numbers::pi;

void expect_dir(glm::dvec3 got, glm::dvec3 want, double tol = 1e-12) {
  EXPECT_NEAR(got.x, want.x, tol);
  EXPECT_NEAR(got.y, want.y, tol);
  EXPECT_NEAR(got.z, want.z, tol);
}

double total_solid_angle(const EnvLayout& l) {
  double sum = 0.0;
  for (int y = 0; y < l.height(); ++y)
    for (int x = 0; x < l.width(); ++x) sum += l.texel_solid_angle(x, y);
  return sum;
}

const Projection kAll[] = {Projection::AngleMap, Projection::LatLong, Projection::Cube};

std::string case_name(const ::testing::TestParamInfo<std::tuple<Projection, int>>& info) {
  return std::string(projection_name(std::get<0>(info.param))) + "_" +
         std::to_string(std::get<1>(info.param));
}

}  // namespace

TEST(Projection, NamesRoundTrip) {
  for (Projection p : kAll) EXPECT_EQ(parse_projection(projection_name(p)), p);
  EXPECT_FALSE(parse_projection("sphere").has_value());
}

TEST(Projection, LayoutShapesAreChecked) {
  EXPECT_EQ(EnvLayout::for_size(Projection::AngleMap, 64).width(), 64);
  EXPECT_EQ(EnvLayout::for_size(Projection::LatLong, 64).width(), 128);
  EXPECT_EQ(EnvLayout::for_size(Projection::Cube, 64).height(), 384);
  EXPECT_THROW(EnvLayout(Projection::AngleMap, 64, 32), std::invalid_argument);
  EXPECT_THROW(EnvLayout(Projection::LatLong, 64, 64), std::invalid_argument);
  EXPECT_THROW(EnvLayout(Projection::Cube, 64, 64), std::invalid_argument);
  EXPECT_THROW(EnvLayout(Projection::LatLong, 0, 0), std::invalid_argument);
  EXPECT_EQ(EnvLayout::guess_projection(512, 256), Projection::LatLong);
  EXPECT_EQ(EnvLayout::guess_projection(256, 256), Projection::AngleMap);
  EXPECT_EQ(EnvLayout::guess_projection(32, 192), Projection::Cube);
  EXPECT_FALSE(EnvLayout::guess_projection(300, 200).has_value());
}

// --- orientation rules ----------------------------------------------------------------------

TEST(AngleMap, CentreIsForwardNotTheBorder) {
  // Thesis Alg. 2.2 returns the border (0.5, 1.0) for the centre direction; ours is the centre.
  const EnvLayout l = EnvLayout::for_size(Projection::AngleMap, 64);
  const glm::dvec2 uv = l.dir_to_uv({0, 0, -1});
  EXPECT_DOUBLE_EQ(uv.x, 0.5);
  EXPECT_DOUBLE_EQ(uv.y, 0.5);
  expect_dir(l.uv_to_dir({0.5, 0.5}), {0, 0, -1});
}

TEST(AngleMap, OrientationRightUpAndRim) {
  const EnvLayout l = EnvLayout::for_size(Projection::AngleMap, 64);
  expect_dir(l.uv_to_dir({1.0, 0.5}), {0, 0, 1});   // the rim is the back pole
  expect_dir(l.uv_to_dir({0.75, 0.5}), {1, 0, 0});  // half way right: +X
  expect_dir(l.uv_to_dir({0.25, 0.5}), {-1, 0, 0});
  expect_dir(l.uv_to_dir({0.5, 0.25}), {0, 1, 0});  // half way up (v grows down): +Y
  expect_dir(l.uv_to_dir({0.5, 0.75}), {0, -1, 0});
  // r is linear in the angle from -Z (Debevec's angular map).
  const double a = 0.3 * kPi;
  const glm::dvec2 uv = l.dir_to_uv({std::sin(a), 0, -std::cos(a)});
  EXPECT_NEAR(uv.x, 0.5 + 0.3 / 2, 1e-12);
  // The back pole maps onto the rim; outside the disk is not on the sphere.
  const glm::dvec2 back = l.dir_to_uv({0, 0, 1});
  EXPECT_NEAR(std::hypot(2 * back.x - 1, 1 - 2 * back.y), 1.0, 1e-12);
  EXPECT_FALSE(l.uv_on_sphere({0.02, 0.02}));
  EXPECT_TRUE(l.uv_on_sphere({0.5, 0.02}));
}

TEST(LatLong, Orientation) {
  const EnvLayout l = EnvLayout::for_size(Projection::LatLong, 64);
  expect_dir(l.uv_to_dir({0.5, 0.5}), {0, 0, -1});  // centre looks forward
  expect_dir(l.uv_to_dir({0.75, 0.5}), {1, 0, 0});  // u grows towards +X
  expect_dir(l.uv_to_dir({0.25, 0.5}), {-1, 0, 0});
  expect_dir(l.uv_to_dir({0.0, 0.5}), {0, 0, 1});  // the seam is behind
  expect_dir(l.uv_to_dir({0.3, 0.0}), {0, 1, 0});  // top row is up
  expect_dir(l.uv_to_dir({0.3, 1.0}), {0, -1, 0});
}

TEST(Cube, FacesFollowTheOpenGLTable) {
  const EnvLayout l = EnvLayout::for_size(Projection::Cube, 16);
  const glm::dvec3 axes[6] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  for (int f = 0; f < 6; ++f) {
    expect_dir(l.uv_to_dir({0.5, (f + 0.5) / 6.0}), axes[f]);
    EXPECT_EQ(EnvLayout::cube_face_of_direction(axes[f]), f);
  }
  // Texel (0,0) of a face is (sc, tc) = (-1, -1): e.g. +X -> (1, 1, 1)/sqrt3 (sc = -z, tc = -y),
  // +Y -> (-1, 1, -1) (sc = x, tc = z), -Z -> (1, 1, -1) (sc = -x, tc = -y).
  const double k = 1.0 / std::sqrt(3.0);
  expect_dir(l.uv_to_dir({0.0, 0.0 / 6}), {k, k, k});
  expect_dir(l.uv_to_dir({0.0, 2.0 / 6}), {-k, k, -k});
  expect_dir(l.uv_to_dir({0.0, 5.0 / 6}), {k, k, -k});
}

TEST(Cube, TiesGoToXThenYThenZ) {
  EXPECT_EQ(EnvLayout::cube_face_of_direction({1, 1, 1}), 0);
  EXPECT_EQ(EnvLayout::cube_face_of_direction({-1, 1, 1}), 1);
  EXPECT_EQ(EnvLayout::cube_face_of_direction({0.5, -1, 1}), 3);
  EXPECT_EQ(EnvLayout::cube_face_of_direction({0, 0.5, -0.5}), 2);
}

TEST(Cube, DirectionsOnAFaceEdgeStayOnTheirFace) {
  // (x, -x, z) lies on the bottom edge of +X; through uv, (0 + ~1) / 6 * height used to round
  // to the first row of -X, the opposite side of the sphere.
  for (int n : {64, 96, 128, 256}) {
    const EnvLayout l = EnvLayout::for_size(Projection::Cube, n);
    for (double z : {-0.5, -0.2151, 0.0, 0.2151, 0.5}) {
      const glm::dvec3 d = glm::normalize(glm::dvec3(0.6906, -0.6906, z));
      const glm::ivec2 t = l.dir_to_texel(d);
      EXPECT_EQ(t.y / n, 0) << "size " << n << " z " << z;
      EXPECT_GT(glm::dot(l.texel_dir(t.x, t.y), d), 0.99) << "size " << n << " z " << z;
    }
  }
}

// --- round trips ------------------------------------------------------------------------------

class RoundTrip : public ::testing::TestWithParam<std::tuple<Projection, int>> {};

TEST_P(RoundTrip, TexelToDirectionToTexelAndUv) {
  const auto [proj, n] = GetParam();
  const EnvLayout l = EnvLayout::for_size(proj, n);
  int checked = 0;
  for (int y = 0; y < l.height(); ++y)
    for (int x = 0; x < l.width(); ++x) {
      const glm::dvec2 uv = l.pixel_to_uv({x + 0.5, y + 0.5});
      if (!l.uv_on_sphere(uv)) continue;
      const glm::dvec3 d = l.texel_dir(x, y);
      ASSERT_NEAR(glm::length(d), 1.0, 1e-14);
      const glm::ivec2 t = l.dir_to_texel(d);
      ASSERT_EQ(t, glm::ivec2(x, y)) << projection_name(proj) << " texel " << x << "," << y;
      const glm::dvec2 back = l.dir_to_uv(d);
      ASSERT_NEAR(back.x, uv.x, 1e-12);
      ASSERT_NEAR(back.y, uv.y, 1e-12);
      ++checked;
    }
  EXPECT_GT(checked, 0);
}

TEST_P(RoundTrip, DirectionToUvToDirection) {
  const auto [proj, n] = GetParam();
  const EnvLayout l = EnvLayout::for_size(proj, n);
  // Random directions plus the special ones: axes, poles, near the angle map's centre and rim.
  std::vector<glm::dvec3> dirs = {{0, 0, -1}, {1e-9, 0, -1}, {0, 1, 0},       {0, -1, 0},
                                  {1, 0, 0},  {-1, 0, 0},    {1e-7, 2e-7, 1}, {0.6, 0.8, 1e-12}};
  std::uint64_t s = 12345;
  auto rnd = [&] {
    s = s * 6364136223846793005ull + 1442695040888963407ull;
    return double(s >> 11) / double(1ull << 53);
  };
  for (int i = 0; i < 2000; ++i) {
    const double z = 2 * rnd() - 1, phi = 2 * kPi * rnd(), r = std::sqrt(1 - z * z);
    dirs.push_back({r * std::cos(phi), r * std::sin(phi), z});
  }
  for (glm::dvec3 d : dirs) {
    d = glm::normalize(d);
    const glm::dvec3 back = l.uv_to_dir(l.dir_to_uv(d));
    const double err = glm::length(back - d);
    // The angle map's rim is one direction (the back pole): there uv -> dir is only accurate to
    // the rounding of r near 1, i.e. sqrt(eps) in angle.
    const double tol = (proj == Projection::AngleMap && d.z > 0.999999) ? 1e-6 : 1e-12;
    ASSERT_LT(err, tol) << projection_name(proj) << " (" << d.x << "," << d.y << "," << d.z << ")";
  }
}

INSTANTIATE_TEST_SUITE_P(AllProjections, RoundTrip,
                         ::testing::Combine(::testing::ValuesIn(kAll), ::testing::Values(1, 7, 64)),
                         case_name);

// --- solid angles -----------------------------------------------------------------------------

class SolidAngle : public ::testing::TestWithParam<std::tuple<Projection, int>> {};

TEST_P(SolidAngle, SumsToFourPi) {
  const auto [proj, n] = GetParam();
  EXPECT_NEAR(total_solid_angle(EnvLayout::for_size(proj, n)), 4 * kPi, 1e-6)
      << projection_name(proj) << " " << n;
}

INSTANTIATE_TEST_SUITE_P(AllProjections, SolidAngle,
                         ::testing::Combine(::testing::ValuesIn(kAll),
                                            ::testing::Values(1, 2, 3, 5, 16, 101, 512)),
                         case_name);

TEST(SolidAngle, AngleMapAgreesWithTheThesisSincWeight) {
  // Thesis Alg. 4.2/4.4: weight (2 pi / n)^2 sinc(pi r) at the texel centre. Inside the disk
  // the exact integral must agree to second order in the texel size.
  const int n = 512;
  const EnvLayout l = EnvLayout::for_size(Projection::AngleMap, n);
  double worst = 0.0;
  for (int y = 0; y < n; y += 7)
    for (int x = 0; x < n; x += 7) {
      const double s = 2.0 * (x + 0.5) / n - 1.0, t = 1.0 - 2.0 * (y + 0.5) / n;
      const double r = std::hypot(s, t);
      if (r > 0.95) continue;
      const double sinc = r == 0 ? 1.0 : std::sin(kPi * r) / (kPi * r);
      const double thesis = std::pow(2 * kPi / n, 2) * sinc;
      worst = std::max(worst, std::abs(l.texel_solid_angle(x, y) / thesis - 1.0));
    }
  EXPECT_LT(worst, 2e-4);
  EXPECT_GT(worst, 0.0);  // not the same formula: the exact one integrates over the texel
}

TEST(SolidAngle, RimTexelsAreClippedToTheDisk) {
  const EnvLayout l = EnvLayout::for_size(Projection::AngleMap, 64);
  EXPECT_EQ(l.texel_solid_angle(0, 0), 0.0);  // corner: wholly outside
  EXPECT_FALSE(l.texel_valid(0, 0));
  EXPECT_GT(l.texel_solid_angle(32, 0), 0.0);  // top middle: on the rim
  // A texel whose centre is outside the disk but which overlaps it still counts, and takes the
  // back-pole direction.
  const int x = 42, y = 1;  // centre at r ~ 1.008, nearest corner at r ~ 0.988
  const double s = 2.0 * (x + 0.5) / 64 - 1, t = 1 - 2.0 * (y + 0.5) / 64;
  ASSERT_GT(std::hypot(s, t), 1.0);
  ASSERT_LT(std::hypot(std::abs(s) - 1.0 / 64, std::abs(t) - 1.0 / 64), 0.99);
  EXPECT_GT(l.texel_solid_angle(x, y), 0.0);
  expect_dir(l.texel_dir(x, y), {0, 0, 1});
}

TEST(SolidAngle, LatLongAndCubeClosedForms) {
  const EnvLayout ll = EnvLayout::for_size(Projection::LatLong, 8);  // 16 x 8
  // Top row: a cap of 22.5 degrees split in 16: 2 pi (1 - cos 22.5deg) / 16.
  EXPECT_NEAR(ll.texel_solid_angle(3, 0), 2 * kPi * (1 - std::cos(kPi / 8)) / 16, 1e-14);
  const EnvLayout cube = EnvLayout::for_size(Projection::Cube, 2);
  // One face quadrant of a cube is 1/24 of the sphere.
  EXPECT_NEAR(cube.texel_solid_angle(1, 7), 4 * kPi / 24, 1e-14);
}

TEST(TexelTable, MatchesTheLayoutAndIsCached) {
  const EnvLayout l = EnvLayout::for_size(Projection::AngleMap, 32);
  const auto t = texel_table(l);
  EXPECT_EQ(t, texel_table(l));
  double sum = 0;
  for (double w : t->solid_angle) sum += w;
  EXPECT_NEAR(sum, 4 * kPi, 1e-9);
  const std::uint32_t i = t->index[t->size() / 2];
  const glm::dvec3 d = l.texel_dir(int(i % 32), int(i / 32));
  EXPECT_EQ(t->x[t->size() / 2], d.x);
  EXPECT_EQ(t->z[t->size() / 2], d.z);
}
