// glTF metallic-roughness in the renderer (issue 34 §3): the split sum with the room's GGX chain.
// A white metal in a constant room reflects the room exactly (the multiple-scattering
// compensation keeps its energy); spheres under a real room agree with the full BRDF integrated
// over the room per pixel; without a chain the reflection maps stand in; bad chains are refused.
#include <glm/geometric.hpp>

#include "arlight/common/brdf.hpp"
#include "arlight/common/hdr_io.hpp"
#include "arlight/common/resample.hpp"
#include "arlight/common/specular_lights.hpp"
#include "arlight/lighting/ggx.hpp"
#include "arlight/render/sample_models.hpp"
#include "render_fixtures.hpp"

namespace arlight::render {
namespace {

using namespace testing;

constexpr int W = SphereScene::W, H = SphereScene::H;

Material pbr(glm::vec3 base, float metallic, float roughness) {
  Material m;
  m.pbr = MetallicRoughness{};
  m.pbr->base_colour = glm::vec4(base, 1.0f);
  m.pbr->metallic = metallic;
  m.pbr->roughness = roughness;
  return m;
}

void set_chain(Renderer& r, const lighting::GgxChain& chain) {
  r.set_ggx_chain(chain.maps(), chain.roughness());
}

// The room the spheres stand in: venice as a face-64 cube (every texel one direction of the
// reference's sum), and its GGX chain 64 -> 8 (4 levels: roughness 0, 0.18, 0.42, 1).
EnvMap probe_cube(const std::string& name) {
  // (load_envmap has set the probe's negative values, lossy compression's, to 0.)
  return resample(load_envmap(std::string(ARLIGHT_ASSETS_DIR) + "/probes/" + name + ".exr").env,
                  EnvLayout::for_size(Projection::Cube, 64));
}
const EnvMap& venice() {
  static const EnvMap env = probe_cube("venice");
  return env;
}
// Park: a sun (a few texels at ~10^4 times the sky, 10 % of the room's light) low over trees.
// Studio: a ring light holding 62 % of the room's light beside a softbox and black walls.
const EnvMap& park() {
  static const EnvMap env = probe_cube("park");
  return env;
}
const EnvMap& studio() {
  static const EnvMap env = probe_cube("studio");
  return env;
}

// The full BRDF over the room at a surface point, multiple scattering included (Kulla & Conty,
// common/brdf.hpp): sum over texels L (f + f_ms)(l, v) (n.l) dw (world frame = the scene's).
glm::dvec3 reference(const EnvMap& env, const glm::dvec3& n, const glm::dvec3& v,
                     const glm::dvec3& base, double metallic, double roughness,
                     const GgxMultipleScattering& ms) {
  const TexelTable& t = *texel_table(env.layout);
  const glm::dvec3 f0 = glm::mix(glm::dvec3(0.04), base, metallic);
  glm::dvec3 sum(0.0);
  for (std::size_t e = 0; e < t.size(); ++e) {
    const glm::dvec3 l(t.x[e], t.y[e], t.z[e]);
    const double nl = glm::dot(n, l);
    if (nl <= 0.0) continue;
    const float* p = env.image.data() + 3 * std::size_t(t.index[e]);
    const glm::dvec3 f = metallic_roughness_brdf(n, l, v, base, metallic, roughness) +
                         ms.brdf(nl, glm::dot(n, v), f0);
    sum += glm::dvec3(p[0], p[1], p[2]) * f * nl * t.solid_angle[e];
  }
  return sum;
}

struct SphereCase {
  glm::vec3 base;
  float metallic, roughness;
};
struct SphereError {
  double overall = 0, head_on = 0;  // mean relative error, and where n.v >= 0.8
  int head_on_values = 0;
};

// The renderer's sphere against the full BRDF over `room` at every third pixel.
SphereError sphere_error(SphereScene& s, const EnvMap& room, const SphereCase& k) {
  const HdrReadback hdr = s.render(pbr(k.base, k.metallic, k.roughness));
  const GgxMultipleScattering ms(k.roughness);
  SphereError e;
  int n = 0;
  for (int y = 0; y < H; y += 3)
    for (int x = 0; x < W; x += 3) {
      if (s.inside(x, y) != 1) continue;
      const glm::dvec3 p = *s.hit(x, y);
      const glm::dvec3 nrm = glm::normalize(p);
      const glm::dvec3 view = glm::normalize(glm::dvec3(0, 0, SphereScene::kDist) - p);
      const glm::dvec3 want = reference(room, nrm, view, glm::dvec3(k.base), k.metallic, k.roughness, ms);
      const glm::vec3 got = hdr.radiance.at(x, y);
      for (int ch = 0; ch < 3; ++ch) {
        const double err = std::abs(got[ch] - want[ch]) / (want[ch] + 1e-4);
        e.overall += err, ++n;
        if (glm::dot(nrm, view) >= 0.8) e.head_on += err, ++e.head_on_values;
      }
    }
  e.overall /= std::max(n, 1);
  e.head_on /= std::max(e.head_on_values, 1);
  return e;
}

}  // namespace

// White furnace: E = b for F0 = 1, and the compensation 1 / b restores what single scattering
// loses, so a white metal shows the room's radiance at every pixel and roughness, through the
// chain and through the reflection maps.
TEST(MetallicRoughness, AWhiteMetalInAConstantRoomReflectsItExactly) {
  SphereScene s;
  const glm::vec3 c(0.5f, 1.0f, 2.0f);
  set_constant_maps(s.r, Projection::Cube, c);
  const EnvMap room = constant_env(Projection::Cube, 16, c);
  const lighting::GgxChain chain = lighting::compute_ggx_chain(room, {.face = 16, .min_face = 2});
  for (bool with_chain : {true, false}) {
    if (with_chain)
      set_chain(s.r, chain);
    else
      s.r.clear_ggx_chain();
    for (float roughness : {0.1f, 0.5f, 1.0f}) {
      const HdrReadback hdr = s.render(pbr(glm::vec3(1.0f), 1.0f, roughness));
      int inside = 0, wrong = 0;
      double worst = 0.0;
      for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x) {
          if (s.inside(x, y) != 1) continue;
          ++inside;
          const glm::vec3 got = hdr.radiance.at(x, y);
          for (int ch = 0; ch < 3; ++ch) {
            const double err = std::abs(got[ch] - c[ch]) / c[ch];
            worst = std::max(worst, err);
            wrong += err > 0.01;
          }
        }
      EXPECT_GT(inside, 1000);
      EXPECT_EQ(wrong, 0) << "roughness " << roughness << (with_chain ? " (chain)" : " (maps)")
                          << ": worst " << worst;
    }
  }
}

// A red dielectric in a white room: the diffuse takes the base colour (R: what the dielectric's
// 4 % Fresnel leaves of the room), green and blue only that Fresnel reflection.
TEST(MetallicRoughness, ADielectricsDiffuseTakesTheBaseColour) {
  SphereScene s;
  const glm::vec3 c(1.0f);
  set_constant_maps(s.r, Projection::Cube, c);
  const EnvMap room = constant_env(Projection::Cube, 16, c);
  set_chain(s.r, lighting::compute_ggx_chain(room, {.face = 16, .min_face = 2}));
  const HdrReadback hdr = s.render(pbr(glm::vec3(1.0f, 0.0f, 0.0f), 0.0f, 0.5f));
  const glm::vec3 centre = hdr.radiance.at(SphereScene::W / 2, SphereScene::H / 2);
  EXPECT_GT(centre.r, 0.9f);
  EXPECT_LT(centre.r, 1.02f);
  EXPECT_NEAR(centre.g, 0.04f, 0.015f);  // F0 head-on (a little more with the rough lobe)
  EXPECT_NEAR(centre.b, centre.g, 1e-3f);
}

// Spheres of three metal / roughness pairs under venice (a sun 10^4 times the sky): the split
// sum against the full BRDF (multiple scattering included) summed over every room texel at each
// pixel's surface point. The split sum assumes n = v = R; its known error grows at grazing views
// (Karis 2013), so the error is held head-on (n.v >= 0.8) and over the whole sphere (measured:
// metal r 0.4 2.7 % / 4.6 %, dielectric r 0.6 0.7 / 0.9 %, half metal r 0.25 1.2 / 2.5 %; with
// one tap of the chain instead of ibl.frag's three along the plane of incidence, the metal's and
// half metal's whole-sphere errors were 7.0 and 3.2 %).
TEST(MetallicRoughness, SpheresUnderARealRoomMatchTheFullBrdf) {
  SphereScene s;
  const lighting::GgxChain chain = lighting::compute_ggx_chain(venice(), {.face = 64, .min_face = 8});
  set_chain(s.r, chain);
  // No irradiance map: with a chain the diffuse light comes from its roughest level.
  struct Case {
    SphereCase sphere;
    double head_on, overall;  // mean error bounds for n.v >= 0.8 and for the whole sphere
  };
  for (const Case& k : {Case{{{0.9f, 0.6f, 0.3f}, 1.0f, 0.4f}, 0.04, 0.055},
                        Case{{{0.8f, 0.8f, 0.8f}, 0.0f, 0.6f}, 0.015, 0.02},
                        Case{{{0.2f, 0.5f, 0.8f}, 0.5f, 0.25f}, 0.03, 0.03}}) {
    const SphereError e = sphere_error(s, venice(), k.sphere);
    ASSERT_GT(e.head_on_values, 500);
    std::printf("metallic %.2f roughness %.2f: mean error %.2f %% (n.v >= 0.8: %.2f %%)\n",
                k.sphere.metallic, k.sphere.roughness, 100 * e.overall, 100 * e.head_on);
    EXPECT_LT(e.head_on, k.head_on);
    EXPECT_LT(e.overall, k.overall);
  }
}

// Park's sun and studio's ring light taken out of the chain (split_specular_lights, issue 51
// §1) and shaded with the full GGX BRDF, the chain holding the residual: against the full BRDF
// over the whole room, the spheres' error falls well below the chain of the whole room's. The
// dielectric's diffuse light comes from the residual chain's roughest level plus the lights'
// (no irradiance map here): studio's ring light lights the side the camera sees.
TEST(MetallicRoughness, ALightTakenOutOfTheChainMeetsTheFullBrdf) {
  SphereScene s;
  const lighting::GgxChainSpec spec{.face = 64, .min_face = 8};
  struct Case {
    const EnvMap* room;
    SphereCase sphere;
    double bound;  // on the mean error with the light analytic
    double ratio;  // ... and on its ratio to the error with the whole room's chain
  };
  // Measured: park 10.0 -> 5.5 %, 13.0 -> 5.9 %, 1.64 -> 1.31 %; studio 15.5 -> 5.1 %,
  // 24.0 -> 18.5 % (its metal's error is the softbox's, still in the chain: bench/RESULTS.md).
  const Case cases[] = {{&park(), {{0.9f, 0.6f, 0.3f}, 1.0f, 0.3f}, 0.07, 0.65},
                        {&park(), {{0.9f, 0.9f, 0.9f}, 1.0f, 0.6f}, 0.075, 0.6},
                        {&park(), {{0.8f, 0.8f, 0.8f}, 0.0f, 0.5f}, 0.016, 0.9},
                        {&studio(), {{0.8f, 0.8f, 0.8f}, 0.0f, 0.5f}, 0.065, 0.45},
                        {&studio(), {{0.9f, 0.6f, 0.3f}, 1.0f, 0.5f}, 0.22, 0.85}};
  const EnvMap* split_of = nullptr;
  std::vector<SpecularLight> lights;
  lighting::GgxChain whole, residual;
  for (const Case& k : cases) {
    if (k.room != split_of) {
      split_of = k.room;
      const SpecularSplit split = split_specular_lights(*k.room);
      ASSERT_EQ(split.lights.size(), 1u);
      lights = split.lights;
      whole = lighting::compute_ggx_chain(*k.room, spec);
      residual = lighting::compute_ggx_chain(split.residual, spec);
    }
    set_chain(s.r, whole);
    const SphereError before = sphere_error(s, *k.room, k.sphere);
    s.r.set_ggx_chain(residual.maps(), residual.roughness(), lights);
    const SphereError after = sphere_error(s, *k.room, k.sphere);
    std::printf("%s metallic %.2f roughness %.2f: mean error %.2f %% with the whole room's chain, "
                "%.2f %% with the light analytic (n.v >= 0.8: %.2f / %.2f %%)\n",
                k.room == &park() ? "park" : "studio", k.sphere.metallic, k.sphere.roughness,
                100 * before.overall, 100 * after.overall, 100 * before.head_on, 100 * after.head_on);
    EXPECT_LT(after.overall, k.bound);
    EXPECT_LT(after.overall, k.ratio * before.overall);
  }
  // Lights the shader cannot hold, or not lights at all, are refused.
  std::vector<SpecularLight> many(kMaxSpecularLights + 1, lights[0]);
  EXPECT_THROW(s.r.set_ggx_chain(residual.maps(), residual.roughness(), many), std::invalid_argument);
  SpecularLight bad = lights[0];
  bad.direction *= 2.0f;
  EXPECT_THROW(s.r.set_ggx_chain(residual.maps(), residual.roughness(), {bad}), std::invalid_argument);
  bad = lights[0];
  bad.power.y = NAN;
  EXPECT_THROW(s.r.set_ggx_chain(residual.maps(), residual.roughness(), {bad}), std::invalid_argument);
}

TEST(MetallicRoughness, AChainThatIsNotFilamentsMappingOrNotHalvingIsRefused) {
  SphereScene s;
  const EnvMap room = constant_env(Projection::Cube, 16, glm::vec3(1.0f));
  const lighting::GgxChain chain = lighting::compute_ggx_chain(room, {.face = 16, .min_face = 4});
  std::vector<double> roughness = chain.roughness();
  roughness[1] = 0.5;
  EXPECT_THROW(s.r.set_ggx_chain(chain.maps(), roughness), std::invalid_argument);
  std::vector<EnvMap> levels = chain.maps();
  levels[2] = constant_env(Projection::Cube, 8, glm::vec3(1.0f));
  EXPECT_THROW(s.r.set_ggx_chain(levels, chain.roughness()), std::invalid_argument);
  EXPECT_THROW(s.r.set_ggx_chain({}, {}), std::invalid_argument);
  EXPECT_NO_THROW(s.r.set_ggx_chain(chain.maps(), chain.roughness()));
}

}  // namespace arlight::render

namespace arlight::render {
namespace {

// arlight's textured test model drawn with its own materials in a white room: the gold tiles
// (metal, base colour texture) come out yellow, the terracotta red, the grooves dark (base colour
// and occlusion textures), the plinth's factor-only glaze near white; drawn with one grey
// material instead, none of that holds. Picked by colour: a wrong texture path or a part drawn
// with the wrong material moves pixels out of those classes.
TEST(MetallicRoughness, AModelsOwnMaterialsDrawEachPartWithItsTextures) {
  SphereScene s;
  const glm::vec3 white(1.0f);
  set_constant_maps(s.r, Projection::Cube, white);
  set_chain(s.r, lighting::compute_ggx_chain(constant_env(Projection::Cube, 16, white),
                                             {.face = 16, .min_face = 2}));
  const GltfModel model = make_tiled_ball(256);
  const GpuMesh mesh(model.mesh);
  // 2 units tall, centred on the view: the ball above the centre, the plinth below.
  const glm::mat4 place = glm::scale(glm::translate(glm::mat4(1.0f), glm::vec3(0.0f, -1.0f, 0.0f)),
                                     glm::vec3(2.0f));
  struct Counts {
    int gold = 0, terracotta = 0, groove = 0, glaze = 0, drawn = 0;
  };
  const auto classify = [&](const HdrReadback& hdr) {
    Counts c;
    for (int y = 0; y < H; ++y)
      for (int x = 0; x < W; ++x) {
        if (!hdr.mask[std::size_t(y) * W + std::size_t(x)]) continue;
        ++c.drawn;
        const glm::vec3 l = hdr.radiance.at(x, y);
        if (y > H * 3 / 4) {  // the plinth's rows
          c.glaze += l.b > 0.75f && l.r < 1.1f && std::abs(l.r - l.b) < 0.1f;
          continue;
        }
        c.gold += l.r > 0.7f && l.g > 0.5f * l.r && l.b < 0.6f * l.r;
        c.terracotta += l.r > 0.3f && l.r < 0.75f && l.g < 0.4f * l.r && l.b < 0.3f * l.r;
        c.groove += l.r < 0.08f && l.g < 0.08f && l.b < 0.08f;
      }
    return c;
  };
  s.r.begin_frame();
  s.r.draw(mesh, model.materials, Material{}, place);
  const Counts own = classify(s.r.read_hdr());
  EXPECT_GT(own.drawn, 4000);
  EXPECT_GT(own.gold, own.drawn / 20) << "gold tiles";
  EXPECT_GT(own.terracotta, own.drawn / 20) << "terracotta tiles";
  EXPECT_GT(own.groove, own.drawn / 400) << "grooves";  // their floors are a pixel wide here
  EXPECT_GT(own.glaze, own.drawn / 50) << "the plinth's glaze";
  s.r.begin_frame();
  s.r.draw(mesh, pbr(glm::vec3(0.5f), 0.0f, 0.5f), place);
  const Counts grey = classify(s.r.read_hdr());
  EXPECT_EQ(grey.gold + grey.terracotta + grey.groove, 0);
}

}  // namespace
}  // namespace arlight::render

namespace arlight::render {
namespace {

// glTF alphaMode BLEND: a surface of coverage a over the camera frame composites as
// a x (what it shows opaque) + (1 - a) x the frame, pixel for pixel (linear tone mapping, so the
// codes are the radiance's); MASK-free and opaque surfaces keep covering the frame completely.
TEST(MetallicRoughness, ABlendedSurfaceShowsTheFrameBehindItByItsCoverage) {
  SphereScene s;
  set_constant_maps(s.r, Projection::Cube, glm::vec3(0.5f));
  const cv::Mat frame(H, W, CV_8UC3, cv::Scalar(40, 120, 200));  // B, G, R
  ToneMapping tone;
  tone.mode = ToneMode::Linear;
  const auto composited = [&](float alpha, bool blend) {
    Material m = pbr(glm::vec3(0.8f, 0.6f, 0.4f), 0.0f, 0.7f);
    m.pbr->base_colour.a = alpha;
    m.pbr->alpha_blend = blend;
    s.r.begin_frame();
    s.r.draw(s.sphere, m, glm::mat4(1.0f));
    cv::Mat out;
    composite(s.r, frame, tone, out);
    return out;
  };
  const cv::Mat opaque = composited(1.0f, false);
  for (const float alpha : {0.25f, 0.6f}) {
    const cv::Mat blended = composited(alpha, true);
    int inside = 0, wrong = 0;
    for (int y = 0; y < H; ++y)
      for (int x = 0; x < W; ++x) {
        if (s.inside(x, y) == 1) {
          ++inside;
          const glm::vec3 want = alpha * bgr_at(opaque, x, y) + (1.0f - alpha) * bgr_at(frame, x, y);
          const glm::vec3 got = bgr_at(blended, x, y);
          for (int c = 0; c < 3; ++c) wrong += std::abs(got[c] - want[c]) > 1.5f;
        } else if (s.inside(x, y) == 0) {
          wrong += bgr_at(blended, x, y) != bgr_at(frame, x, y);
        }
      }
    EXPECT_GT(inside, 1000);
    EXPECT_EQ(wrong, 0) << "alpha " << alpha;
  }
  // The same material with coverage 1 is the opaque one exactly.
  const cv::Mat full = composited(1.0f, true);
  int differ = 0;
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) differ += bgr_at(full, x, y) != bgr_at(opaque, x, y);
  EXPECT_EQ(differ, 0);
}

}  // namespace
}  // namespace arlight::render
