// arlight_lighting's split-sum part: the GGX chain against the exact prefilter on real probes
// and its level <-> roughness mapping (the DFG table is common's: tests/common/test_brdf.cpp).
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <random>
#include <stop_token>

#include <glm/geometric.hpp>

#include "../support/env_fixtures.hpp"
#include "arlight/common/error.hpp"
#include "arlight/common/hdr_io.hpp"
#include "arlight/lighting/ggx.hpp"

using namespace arlight;
using namespace arlight::lighting;

namespace {

const std::filesystem::path kProbes = std::filesystem::path(ARLIGHT_SOURCE_DIR) / "data/probes";

struct Errors {
  double mean = 0, max = 0;
};

// The errors (thesis eqs. 6.1, 6.2) of `map` against the exact prefilter at `count` random
// valid texels, every channel, eps = 1e-4 x the sample's mean.
Errors errors_against_exact(const EnvMap& input, const EnvMap& map, double roughness, int count,
                            unsigned seed) {
  const TexelTable& t = *texel_table(map.layout);
  std::mt19937 rng(seed);
  std::uniform_int_distribution<std::size_t> pick(0, t.size() - 1);
  std::vector<glm::dvec3> dirs;
  std::vector<std::uint32_t> pixels;
  for (int i = 0; i < count; ++i) {
    const std::size_t e = pick(rng);
    dirs.emplace_back(t.x[e], t.y[e], t.z[e]);
    pixels.push_back(t.index[e]);
  }
  const auto exact = ggx_prefilter_exact(input, roughness, dirs);
  double mean_ref = 0;
  for (const auto& v : exact) mean_ref += (v.x + v.y + v.z) / 3.0;
  const double eps = 1e-4 * mean_ref / double(count);
  Errors e;
  for (std::size_t i = 0; i < exact.size(); ++i)
    for (int c = 0; c < 3; ++c) {
      const double ref = exact[i][c], got = map.image.data()[3 * std::size_t(pixels[i]) + std::size_t(c)];
      const double err = std::abs(got - ref) / (ref + eps);
      e.mean += err / (3.0 * double(count));
      e.max = std::max(e.max, err);
    }
  return e;
}

}  // namespace

TEST(GgxLevels, FilamentMapping) {
  EXPECT_DOUBLE_EQ(ggx_level_roughness(0, 5), 0.0);
  EXPECT_NEAR(ggx_level_roughness(1, 5), 1.0 - std::sqrt(0.75), 1e-12);
  EXPECT_NEAR(ggx_level_roughness(2, 5), 1.0 - std::sqrt(0.5), 1e-12);
  EXPECT_NEAR(ggx_level_roughness(3, 5), 0.5, 1e-12);
  EXPECT_DOUBLE_EQ(ggx_level_roughness(4, 5), 1.0);
  for (int k = 0; k < 6; ++k)
    EXPECT_NEAR(ggx_roughness_level(ggx_level_roughness(k, 6), 6), k, 1e-9) << k;
}

TEST(GgxChain, ConstantEnvironmentStaysConstant) {
  // Alg. 4.1's normalisation: the lobe-weighted mean of a constant is that constant.
  const EnvMap env(EnvLayout(Projection::LatLong, 128, 64),
                   Image(128, 64, glm::vec3(0.5f, 1.0f, 2.0f)));
  const GgxChain chain = compute_ggx_chain(env, {.face = 32, .min_face = 4});
  ASSERT_EQ(chain.levels.size(), 4u);
  for (const GgxLevel& level : chain.levels) {
    EXPECT_EQ(level.map.layout.face_size(), 32 >> level.level);
    for (std::size_t i = 0; i < level.map.image.texel_count(); ++i) {
      const float* v = level.map.image.data() + 3 * i;
      ASSERT_NEAR(v[0], 0.5f, 1e-3f) << "level " << level.level;
      ASSERT_NEAR(v[2], 2.0f, 4e-3f) << "level " << level.level;
    }
  }
}

TEST(GgxChain, RoughnessOneIsTheIrradianceMap) {
  // D is constant at alpha = 1: the lobe is (R.l)+, the thesis's s = 1 map.
  const EnvMap env = load_envmap(kProbes / "park.exr").env;
  const EnvLayout out(Projection::Cube, 16, 96);
  const EnvMap ggx = ggx_prefilter(env, 1.0, out);
  const double s = 1.0;
  const ComputedMapSet phong = compute_maps(env, std::span(&s, 1), out, parse_method("accurate"));
  const MapError e = map_error(phong.maps[0], ggx);
  EXPECT_LT(e.mean, 0.002);
  EXPECT_LT(e.max, 0.01);
}

TEST(GgxChain, MeetsTheExactPrefilterOnThreeProbes) {
  // Mean <= 0.5 %, max <= 3 % at every level (issue 34), here at face 128 of the full probes;
  // the benchmark (bench/ggx_vs_cmgen.cpp, arlight-bench-ggx) measures face 256.
  for (const char* probe : {"park.exr", "venice.exr", "studio.exr"}) {
    const EnvMap env = load_envmap(kProbes / probe).env;
    const GgxChain chain = compute_ggx_chain(env, {.face = 128, .min_face = 16});
    ASSERT_EQ(chain.levels.size(), 4u);
    for (std::size_t k = 1; k < chain.levels.size(); ++k) {
      const GgxLevel& level = chain.levels[k];
      const Errors e = errors_against_exact(env, level.map, level.roughness, 400, unsigned(k));
      EXPECT_LT(e.mean, 0.005) << probe << " level " << k << " r=" << level.roughness;
      EXPECT_LT(e.max, 0.03) << probe << " level " << k << " r=" << level.roughness;
    }
  }
}

TEST(GgxChain, AnyOutputLayoutAgreesWithTheCube) {
  // The same prefilter in the input's own lat-long layout (arlight-maps ggx --latlong).
  const EnvMap env = load_envmap(kProbes / "venice.exr").env;
  const EnvLayout latlong(Projection::LatLong, 64, 32);
  const EnvMap map = ggx_prefilter(env, 0.5, latlong);
  const Errors e = errors_against_exact(env, map, 0.5, 300, 7);
  EXPECT_LT(e.mean, 0.005);
  EXPECT_LT(e.max, 0.03);
}

TEST(GgxChain, BadRequestsAndInputsSayWhatIsWrong) {
  const EnvMap env(EnvLayout(Projection::LatLong, 32, 16), Image(32, 16, glm::vec3(1.0f)));
  EXPECT_THROW(compute_ggx_chain(env, {.face = 100}), InputError);
  EXPECT_THROW(compute_ggx_chain(env, {.face = 64, .min_face = 128}), InputError);
  EXPECT_THROW(ggx_prefilter(env, 0.0, EnvLayout(Projection::Cube, 8, 48)), InputError);
  EnvMap bad = env;
  bad.image.set(3, 4, glm::vec3(-1.0f));
  try {
    compute_ggx_chain(bad, {.face = 16, .min_face = 4});
    FAIL() << "a negative texel was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("negative"), std::string::npos) << e.what();
  }
}

TEST(GgxChain, StopsWhenAsked) {
  const EnvMap env = load_envmap(kProbes / "park.exr").env;
  std::stop_source stop;
  Hooks hooks;
  int tiles = 0;
  hooks.stop = stop.get_token();
  hooks.on_tile = [&](const TileDone&) {
    if (++tiles == 3) stop.request_stop();
  };
  EXPECT_THROW(compute_ggx_chain(env, {.face = 64, .min_face = 8}, hooks), Cancelled);
}
