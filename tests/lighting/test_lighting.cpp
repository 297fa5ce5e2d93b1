// arlight_lighting: every method against known answers and against each other.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <glm/geometric.hpp>
#include <numbers>
#include <stop_token>

#include "../support/env_fixtures.hpp"
#include "arlight/common/error.hpp"
#include "arlight/common/hdr_io.hpp"
#include "arlight/common/resample.hpp"
#include "arlight/lighting/lighting.hpp"

using namespace arlight;
using namespace arlight::lighting;

namespace {

const std::vector<double> kThesisShininess = {1, 10, 20, 40, 80, 160, 320, 1280};
const char* kAllMethods[] = {"accurate", "mipmap", "sh:8", "bounded", "importance:16", "auto"};

// Calls fn(value, x, y) for every valid texel of `map`, channel 0.
template <class Fn>
void for_valid(const EnvMap& map, Fn fn) {
  const auto t = texel_table(map.layout);
  for (std::size_t i = 0; i < t->size(); ++i) {
    const std::uint32_t px = t->index[i];
    fn(map.image.data()[3 * px], glm::dvec3(t->x[i], t->y[i], t->z[i]));
  }
}

// A smooth environment with some structure: ambient, a sky gradient and two soft lights.
EnvMap smooth_env(const EnvLayout& layout) {
  return test::env_from_function(layout, [](glm::dvec3 d) {
    const glm::dvec3 l1 = glm::normalize(glm::dvec3(0.3, 0.8, -0.5));
    const glm::dvec3 l2 = glm::normalize(glm::dvec3(-0.7, 0.1, 0.7));
    const double a = std::exp(8.0 * (glm::dot(d, l1) - 1.0)),
                 b = std::exp(20.0 * (glm::dot(d, l2) - 1.0));
    return glm::vec3(float(0.2 + 0.1 * d.y + 4.0 * a + 2.0 * b), float(0.25 + 3.0 * a + 1.0 * b),
                     float(0.3 + 0.15 * d.y + 1.0 * a + 3.0 * b));
  });
}

const std::filesystem::path kProbes = std::filesystem::path(ARLIGHT_SOURCE_DIR) / "data/probes";

}  // namespace

// ---- method names ----------------------------------------------------------------------------

TEST(Method, NamesRoundTrip) {
  for (const char* name : {"accurate", "mipmap", "sh:35", "bounded", "importance:64", "auto"})
    EXPECT_EQ(parse_method(name).name(), name);
  EXPECT_EQ(parse_method("sh", 12).name(), "sh:12");
  EXPECT_EQ(parse_method("importance", 35, 7).name(), "importance:7");
  EXPECT_EQ(parse_method("sh:9").sh_order, 9);
}

TEST(Method, BadNamesSayWhatIsValid) {
  for (const char* bad :
       {"fast", "sh:", "sh:x", "sh:0", "sh:500", "accurate:3", "importance:-1", ""}) {
    try {
      parse_method(bad);
      ADD_FAILURE() << bad << " accepted";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("valid:"), std::string::npos) << e.what();
    }
  }
}

TEST(Compute, RejectsShininessBelowOne) {
  const EnvMap env(EnvLayout::for_size(Projection::AngleMap, 8));
  const double bad[] = {1.0, 0.5};
  EXPECT_THROW(compute_maps(env, bad, env.layout, parse_method("accurate")), std::invalid_argument);
  EXPECT_THROW(compute_maps(env, {}, env.layout, parse_method("accurate")), std::invalid_argument);
}

// ---- constants -------------------------------------------------------------------------------

class EveryMethod : public ::testing::TestWithParam<const char*> {};

TEST_P(EveryMethod, ConstantEnvironmentGivesTheConstantInEveryMap) {
  const glm::vec3 c(0.7f, 1.3f, 2.1f);
  for (Projection in_p : {Projection::AngleMap, Projection::LatLong, Projection::Cube}) {
    const EnvLayout in_l = EnvLayout::for_size(in_p, 32);
    const EnvMap env = test::env_from_function(in_l, [&](glm::dvec3) { return c; });
    for (Projection out_p : {Projection::AngleMap, Projection::LatLong, Projection::Cube}) {
      const EnvLayout out_l = EnvLayout::for_size(out_p, 16);
      const ComputedMapSet set = compute_maps(env, kThesisShininess, out_l, parse_method(GetParam()));
      ASSERT_EQ(set.maps.size(), kThesisShininess.size());
      for (std::size_t k = 0; k < set.maps.size(); ++k) {
        const auto t = texel_table(out_l);
        for (std::size_t i = 0; i < t->size(); ++i)
          for (int ch = 0; ch < 3; ++ch)
            ASSERT_NEAR(set.maps[k].image.data()[3 * t->index[i] + ch], c[ch], 2e-4 * c[ch])
                << GetParam() << " s=" << kThesisShininess[k] << " " << projection_name(in_p)
                << " -> " << projection_name(out_p);
      }
    }
  }
}

INSTANTIATE_TEST_SUITE_P(Lighting, EveryMethod, ::testing::ValuesIn(kAllMethods));

// ---- one bright texel ------------------------------------------------------------------------

TEST(Lobe, OneBrightTexelGivesTheLobesShape) {
  // A single bright texel at p on black: the map at d is L w f(d.p) / sum f w, so across the
  // map it must follow (d.p)^s (the denominator barely varies), peaking at p.
  const EnvLayout l = EnvLayout::for_size(Projection::Cube, 24);
  EnvMap env(l);
  const glm::ivec2 at{7, 2 * 24 + 9};
  env.image.set(at.x, at.y, glm::vec3(1000.0f));
  const glm::dvec3 p = l.texel_dir(at.x, at.y);
  for (const char* method : {"accurate", "bounded", "auto"})
    for (double s : {1.0, 20.0, 200.0}) {
      const double one[] = {s};
      const ComputedMapSet set = compute_maps(env, one, l, parse_method(method));
      const double peak = set.maps[0].image.at(at.x, at.y).x;
      ASSERT_GT(peak, 0.0);
      for_valid(set.maps[0], [&](float v, glm::dvec3 d) {
        const double expected = peak * std::pow(std::max(0.0, glm::dot(d, p)), s);
        ASSERT_NEAR(v, expected, 0.02 * peak + 1e-6) << method << " s=" << s;
      });
    }
}

// ---- analytic answers ------------------------------------------------------------------------

TEST(Sh, ZonalCoefficientsReproduceTheIrradianceOfALinearEnvironment) {
  // L(w) = a + b.w. Its cosine-weighted mean over the hemisphere around n is a + 2/3 b.n
  // (the mean of w over that hemisphere is 2/3 n), which SH order 2 holds exactly.
  const glm::dvec3 b(0.5, -0.2, 0.3);
  const EnvLayout l = EnvLayout::for_size(Projection::LatLong, 64);
  const EnvMap env = test::env_from_function(
      l, [&](glm::dvec3 d) { return glm::vec3(float(1.0 + glm::dot(b, d))); });
  const double one[] = {1.0};
  for (const char* method : {"sh:2", "sh:8", "accurate", "auto"}) {
    const ComputedMapSet set =
        compute_maps(env, one, EnvLayout::for_size(Projection::Cube, 12), parse_method(method));
    for_valid(set.maps[0], [&](float v, glm::dvec3 n) {
      ASSERT_NEAR(v, 1.0 + 2.0 / 3.0 * glm::dot(b, n), 2e-3) << method;
    });
  }
}

TEST(Mipmap, LevelsFollowEquations41To43) {
  // N = 512: l_max = 9; irradiance 4x4 -> 7; s = 10 -> 9 - log2(5); s >= 2N clamps to 0.
  const EnvLayout l = EnvLayout::for_size(Projection::AngleMap, 512);
  const EnvMap env = smooth_env(l);
  const double s[] = {1, 8, 10, 1280};
  const ComputedMapSet set =
      compute_maps(env, s, EnvLayout::for_size(Projection::AngleMap, 16), parse_method("mipmap"));
  EXPECT_NE(set.plans[0].find("level 7.0"), std::string::npos) << set.plans[0];
  EXPECT_NE(set.plans[1].find("level 7.0"), std::string::npos) << set.plans[1];
  EXPECT_NE(set.plans[2].find("level " + std::to_string(9 - std::log2(5.0))), std::string::npos)
      << set.plans[2];
  EXPECT_NE(set.plans[3].find("level 0.0"), std::string::npos) << set.plans[3];
}

// ---- agreement -------------------------------------------------------------------------------

TEST(Agreement, MethodsAgreeWithAccurateOnSmoothInput) {
  for (int size : {64, 128}) {
    const EnvLayout l = EnvLayout::for_size(Projection::AngleMap, size);
    const EnvMap env = smooth_env(l);
    const double s[] = {1, 10, 80, 640};
    const ComputedMapSet ref = compute_maps(env, s, l, parse_method("accurate"));
    struct Expect {
      const char* method;
      double mean, max;  // per shininess: tolerances as fractions
    };
    for (const Expect& e : {Expect{"bounded", 1e-4, 1e-3}, Expect{"auto", 0.005, 0.05}}) {
      const ComputedMapSet set = compute_maps(env, s, l, parse_method(e.method));
      for (std::size_t k = 0; k < 4; ++k) {
        const MapError err = map_error(ref.maps[k], set.maps[k]);
        EXPECT_LE(err.mean, e.mean) << e.method << " size " << size << " s=" << s[k];
        EXPECT_LE(err.max, e.max) << e.method << " size " << size << " s=" << s[k];
      }
    }
    // SH resolves the lobes its order can hold (order 24: s <= ~20), and importance sampling
    // converges with samples.
    const ComputedMapSet sh = compute_maps(env, s, l, parse_method("sh:24"));
    for (std::size_t k = 0; k < 2; ++k)
      EXPECT_LE(map_error(ref.maps[k], sh.maps[k]).max, 0.01)
          << "sh:24 size " << size << " s=" << s[k];
    const ComputedMapSet few = compute_maps(env, s, l, parse_method("importance:8"));
    const ComputedMapSet many = compute_maps(env, s, l, parse_method("importance:512"));
    for (std::size_t k = 0; k < 4; ++k) {
      const double e_few = map_error(ref.maps[k], few.maps[k]).mean;
      const double e_many = map_error(ref.maps[k], many.maps[k]).mean;
      EXPECT_LT(e_many, e_few) << "importance size " << size << " s=" << s[k];
      EXPECT_LE(e_many, 0.03) << "importance:512 size " << size << " s=" << s[k];
    }
  }
}

TEST(Agreement, JointMapsEqualMapsComputedAlone) {
  // The accurate method raises cosines by a chain (c^10 -> c^20 -> ...) and by exp/log for
  // exponents that are not multiples; each map must equal the one computed on its own.
  const EnvLayout l = EnvLayout::for_size(Projection::Cube, 10);
  const EnvMap env = smooth_env(l);
  const std::vector<double> s = {1, 2.5, 10, 30, 45.5, 1280};
  const ComputedMapSet joint = compute_maps(env, s, l, parse_method("accurate"));
  for (std::size_t k = 0; k < s.size(); ++k) {
    const double one[] = {s[k]};
    const ComputedMapSet alone = compute_maps(env, one, l, parse_method("accurate"));
    EXPECT_LE(map_error(alone.maps[0], joint.maps[k]).max, 1e-5) << "s=" << s[k];
  }
}

TEST(Agreement, OutputProjectionDoesNotChangeTheAnswer) {
  // The same maps computed straight into a cube map and into a lat-long map, then compared at
  // the cube's texels.
  const EnvMap env = smooth_env(EnvLayout::for_size(Projection::AngleMap, 64));
  const double s[] = {1, 40};
  const EnvLayout cube = EnvLayout::for_size(Projection::Cube, 16);
  for (const char* method : {"accurate", "auto", "sh:16"}) {
    const ComputedMapSet direct = compute_maps(env, s, cube, parse_method(method));
    const ComputedMapSet ll =
        compute_maps(env, s, EnvLayout::for_size(Projection::LatLong, 128), parse_method(method));
    for (std::size_t k = 0; k < 2; ++k) {
      const EnvMap via = resample(ll.maps[k], cube);
      EXPECT_LE(map_error(direct.maps[k], via).mean, 0.01) << method << " s=" << s[k];
    }
  }
}

// ---- the thesis's pattern on a real probe ----------------------------------------------------

TEST(RealProbe, ThesisTable61PatternHoldsAndAutoMeetsItsTarget) {
  const auto path = kProbes / "venice.exr";
  if (!std::filesystem::exists(path)) GTEST_SKIP() << path << " missing";
  const EnvLayout l = EnvLayout::for_size(Projection::AngleMap, 128);
  const EnvMap env = resample(load_envmap(path).env, l);
  const ComputedMapSet ref = compute_maps(env, kThesisShininess, l, parse_method("accurate"));
  const ComputedMapSet mm = compute_maps(env, kThesisShininess, l, parse_method("mipmap"));
  const ComputedMapSet sh = compute_maps(env, kThesisShininess, l, parse_method("sh:35"));
  const ComputedMapSet au = compute_maps(env, kThesisShininess, l, parse_method("auto"));
  std::vector<MapError> e_mm, e_sh;
  for (std::size_t k = 0; k < kThesisShininess.size(); ++k) {
    e_mm.push_back(map_error(ref.maps[k], mm.maps[k]));
    e_sh.push_back(map_error(ref.maps[k], sh.maps[k]));
    const MapError e_au = map_error(ref.maps[k], au.maps[k]);
    EXPECT_LE(e_au.mean, 0.005) << "auto s=" << kThesisShininess[k];
    EXPECT_LE(e_au.max, 0.05) << "auto s=" << kThesisShininess[k];
  }
  for (std::size_t k = 0; kThesisShininess[k] <= 80; ++k)
    EXPECT_GT(e_mm[k].mean, 10 * e_sh[k].mean) << "s=" << kThesisShininess[k];
  // sh:35's error climbs once the lobes are narrower than order 35 resolves.
  EXPECT_GT(e_sh[6].mean, 3 * e_sh[4].mean);  // s = 320 vs s = 80
  EXPECT_GT(e_sh[7].mean, e_sh[6].mean);      // s = 1280 vs s = 320
  EXPECT_GT(e_sh[7].max, 0.5);
}

// At 256^2 auto takes the paths a 128^2 map does not (issue 37): the irradiance map's SH part
// read from a grid, the bright lights summed at every texel, the direct lobes over prefiltered
// levels built while SH runs, each group of directions summing only the cells in its reach.
TEST(RealProbe, AutoMeetsItsTargetAt256OnEveryPath) {
  const auto path = kProbes / "studio.exr";  // the probe with the most bright texels
  if (!std::filesystem::exists(path)) GTEST_SKIP() << path << " missing";
  const EnvLayout l = EnvLayout::for_size(Projection::AngleMap, 256);
  const EnvMap env = resample(load_envmap(path).env, l);
  const ComputedMapSet ref = compute_maps(env, kThesisShininess, l, parse_method("accurate"));
  const ComputedMapSet au = compute_maps(env, kThesisShininess, l, parse_method("auto"));
  EXPECT_NE(au.plans[0].find("grid"), std::string::npos) << au.plans[0];
  for (std::size_t k = 0; k < kThesisShininess.size(); ++k) {
    const MapError e = map_error(ref.maps[k], au.maps[k]);
    EXPECT_LE(e.mean, 0.005) << "auto s=" << kThesisShininess[k] << ": " << au.plans[k];
    EXPECT_LE(e.max, 0.05) << "auto s=" << kThesisShininess[k] << ": " << au.plans[k];
  }
}

// A night sky: thousands of small lights, 200x the dark sky (issue 50 §4: a probe the project
// never saw had 8,432 bright texels, and summing each at every texel took half of auto's time).
// The irradiance lobe is linear in the direction wherever it is not clamped, so auto sums a cell
// of lights wholly above a texel's horizon as one dot product and only the cells on the horizon
// light by light: the map must still equal accurate's, terminators included.
TEST(Auto, ManySmallLightsGiveTheIrradianceOfEveryLight) {
  const EnvLayout l = EnvLayout::for_size(Projection::AngleMap, 128);
  std::size_t lights = 0;
  EnvMap env = test::env_from_function(l, [](glm::dvec3 d) {
    return glm::vec3(0.02f + 0.01f * float(d.y), 0.02f, 0.03f);
  });
  for (int y = 0; y < l.height(); ++y)
    for (int x = 0; x < l.width(); ++x)
      if (l.texel_valid(x, y) && (x * 7 + y * 13) % 11 == 0 && (x / 8 + y / 8) % 3 == 0) {
        env.image.set(x, y, glm::vec3(4.0f + float(x % 5), 4.0f, 3.0f));
        ++lights;
      }
  ASSERT_GT(lights, 200u);
  const double s[] = {1};
  const ComputedMapSet ref = compute_maps(env, s, l, parse_method("accurate"));
  const ComputedMapSet au = compute_maps(env, s, l, parse_method("auto"));
  const MapError e = map_error(ref.maps[0], au.maps[0]);
  EXPECT_LE(e.mean, 0.001) << au.plans[0];
  EXPECT_LE(e.max, 0.01) << au.plans[0];
}

// ---- progress and cancellation ---------------------------------------------------------------

TEST(Hooks, EveryTileOfEveryMapIsReportedOnce) {
  const EnvMap env = smooth_env(EnvLayout::for_size(Projection::AngleMap, 32));
  const EnvLayout out = EnvLayout::for_size(Projection::LatLong, 40);  // 80 x 40: 3 x 2 tiles
  const double s[] = {1, 50};
  for (const char* method : kAllMethods) {
    std::size_t calls = 0, total = 0, last_done = 0, area = 0;
    Hooks hooks;
    hooks.on_tile = [&](const TileDone& t) {
      ++calls;
      total = t.total;
      EXPECT_EQ(t.done, last_done + 1);
      last_done = t.done;
      area += std::size_t(t.width) * std::size_t(t.height);
    };
    compute_maps(env, s, out, parse_method(method), hooks);
    EXPECT_EQ(calls, 12u) << method;
    EXPECT_EQ(total, 12u) << method;
    EXPECT_EQ(area, 2u * 80u * 40u) << method;
  }
}

TEST(Hooks, StopRequestCancels) {
  const EnvMap env = smooth_env(EnvLayout::for_size(Projection::AngleMap, 64));
  for (const char* method : kAllMethods) {
    std::stop_source source;
    Hooks hooks;
    hooks.stop = source.get_token();
    hooks.on_tile = [&](const TileDone&) { source.request_stop(); };
    EXPECT_THROW(compute_maps(env, kThesisShininess, env.layout, parse_method(method), hooks),
                 Cancelled)
        << method;
  }
}

// ---- errors (eqs. 6.1, 6.2) ------------------------------------------------------------------

TEST(MapError, MeanAndMaxOfRelativeDifferences) {
  const EnvLayout l = EnvLayout::for_size(Projection::LatLong, 4);  // 8 x 4, all valid
  EnvMap a(l, Image(8, 4, glm::vec3(2.0f))), v = a;
  v.image.set(0, 0, glm::vec3(3.0f, 2.0f, 2.0f));  // one channel 50 % off
  const MapError e = map_error(a, v);
  const double eps = 1e-4 * 2.0;
  EXPECT_NEAR(e.max, 1.0 / (2.0 + eps), 1e-12);
  EXPECT_NEAR(e.mean, e.max / 96.0, 1e-12);
  EXPECT_EQ(map_error(a, a).max, 0.0);
  const EnvMap black(l);
  EXPECT_EQ(map_error(black, black).max, 0.0);
  EXPECT_GT(map_error(black, a).mean, 1.0);
}

TEST(Compute, BlackEnvironmentGivesBlackMaps) {
  const EnvMap env(EnvLayout::for_size(Projection::AngleMap, 64));
  for (const char* method : kAllMethods) {
    const ComputedMapSet set = compute_maps(env, kThesisShininess, EnvLayout::for_size(Projection::Cube, 8),
                                    parse_method(method));
    for (const EnvMap& m : set.maps)
      for (float v : m.image.storage()) ASSERT_EQ(v, 0.0f) << method;
  }
}
