// KTX 2.0 cube chains: what encode writes decodes to the same texels (to half precision), the
// header says what the format requires, and a damaged file is refused with its fault named.
#include <gtest/gtest.h>

#include "../support/env_fixtures.hpp"
#include "arlight/common/error.hpp"
#include "arlight/common/ktx2.hpp"
#include "arlight/common/light_files.hpp"

using namespace arlight;

namespace {

std::vector<EnvMap> chain(int face, int levels) {
  std::vector<EnvMap> maps;
  for (int k = 0; k < levels; ++k) {
    const int f = face >> k;
    maps.push_back(test::env_from_function(EnvLayout(Projection::Cube, f, 6 * f), [k](glm::dvec3 d) {
      return glm::vec3(float(1.0 + d.x), float(2.0 + d.y * k), float(100.0 * (1.5 + d.z)));
    }));
  }
  return maps;
}

std::uint32_t u32(const std::vector<std::uint8_t>& b, std::size_t at) {
  return std::uint32_t(b[at]) | std::uint32_t(b[at + 1]) << 8 | std::uint32_t(b[at + 2]) << 16 |
         std::uint32_t(b[at + 3]) << 24;
}

}  // namespace

TEST(Ktx2, RoundTripsACubeChain) {
  const auto maps = chain(16, 3);
  const auto bytes = encode_ktx2_cube(maps, {{"zeta", "last"}, {"arlight.test", "x"}});
  EXPECT_EQ(u32(bytes, 12), kVkFormatR16G16B16A16Sfloat);
  EXPECT_EQ(u32(bytes, 36), 6u);  // faceCount
  EXPECT_EQ(u32(bytes, 40), 3u);  // levelCount
  const Ktx2Cube back = decode_ktx2_cube(bytes);
  ASSERT_EQ(back.levels.size(), 3u);
  for (std::size_t k = 0; k < 3; ++k) {
    ASSERT_EQ(back.levels[k].layout, maps[k].layout);
    const auto& a = maps[k].image.storage();
    const auto& b = back.levels[k].image.storage();
    for (std::size_t i = 0; i < a.size(); ++i) ASSERT_NEAR(b[i], a[i], 1e-3 * a[i] + 1e-4) << k << " " << i;
  }
  // Keys sorted by code point, as the format requires, with the writer's.
  ASSERT_EQ(back.key_values.size(), 3u);
  EXPECT_EQ(back.key_values[0].first, "KTXwriter");
  EXPECT_EQ(back.key_values[1].first, "arlight.test");
  EXPECT_EQ(back.key_values[2], (std::pair<std::string, std::string>{"zeta", "last"}));
}

TEST(Ktx2, LevelsAreStoredSmallestFirstAndAligned) {
  const auto bytes = encode_ktx2_cube(chain(8, 4));
  std::uint64_t previous = 0;
  for (int k = 3; k >= 0; --k) {
    const std::uint64_t at = u32(bytes, 80 + 24 * std::size_t(k));
    EXPECT_EQ(at % 8, 0u);
    EXPECT_GT(at, previous);
    previous = at;
  }
}

TEST(Ktx2, DamagedFilesAreRefusedByName) {
  const auto good = encode_ktx2_cube(chain(8, 2));
  auto expect_error = [](std::vector<std::uint8_t> b, const std::string& words) {
    try {
      decode_ktx2_cube(b);
      FAIL() << "accepted a file with " << words;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << e.what();
    }
  };
  expect_error(std::vector<std::uint8_t>(good.begin(), good.begin() + 40), "identifier");
  auto truncated = good;
  truncated.resize(good.size() - 100);
  expect_error(truncated, "beyond the end");
  auto format = good;
  format[12] = 37;  // R8G8B8A8_SRGB
  expect_error(format, "vkFormat 37");
  auto faces = good;
  faces[36] = 1;
  expect_error(faces, "not a cube map");
  EXPECT_THROW(encode_ktx2_cube(std::vector<EnvMap>{chain(8, 1)[0], chain(8, 1)[0]}), std::invalid_argument);
}

TEST(LightFiles, ShShapesFollowTheirEngines) {
  ShCoeffs sh(3);
  for (int i = 0; i < 9; ++i) sh.c[std::size_t(i)] = glm::dvec3(i + 1, 10 * (i + 1), 100 * (i + 1));
  const auto webxr = sh9_webxr(sh), filament = sh9_filament(sh), unity = sh9_unity(sh);
  EXPECT_FLOAT_EQ(webxr[3 * 4 + 1], 50.0f);                     // (2,-2), green
  EXPECT_NEAR(filament[0], 1.0 * 0.2820948, 1e-6);              // Y00 A0 / pi
  EXPECT_NEAR(filament[3 * 1], 2.0 * 0.4886025 * 2.0 / 3.0, 1e-6);  // band 1: A1 / pi = 2/3
  EXPECT_NEAR(filament[3 * 8], 9.0 * 0.5462742 / 4.0, 1e-6);    // band 2: A2 / pi = 1/4
  EXPECT_FLOAT_EQ(unity[9 * 2 + 2], -300.0f);                   // blue (1,0): z mirrored
  EXPECT_FLOAT_EQ(unity[9 * 0 + 3], 4.0f);                      // red (1,1) kept
  EXPECT_THROW(sh9_webxr(ShCoeffs(2)), std::invalid_argument);
}
