// Hemisphere shading (dissertation §5.4): the colour priors from the lighting, eq. 6 on a
// sphere (diffuse at the normal, specular at the reflected direction) by the world's up axis,
// and hemisphere occlusion.
//
// The rooms are sums of steps, L(d) = c + s_y sign(d.y) + s_x sign(d.x). A step's band 1 is
// (3/2) d.e and the clamped-cosine convolution keeps only bands 0 and 1 of an odd function, so
// the irradiance map is exactly Lbar(n) = c + s_y n.y + s_x n.x: c_u = c + s_y, c_l = c - s_y,
// the lit and dark sides c +- s_x.
#include "arlight/common/sh.hpp"
#include "render_fixtures.hpp"

namespace arlight::render {
namespace {

using namespace testing;

constexpr int W = SphereScene::W, H = SphereScene::H;

const glm::dvec3 kC(1.0, 0.9, 0.8), kSy(0.6, 0.3, -0.2);

EnvMap step_room(glm::dvec3 s_x) {
  const EnvLayout layout = EnvLayout::for_size(Projection::LatLong, 128);
  EnvMap env(layout);
  for (int y = 0; y < layout.height(); ++y)
    for (int x = 0; x < layout.width(); ++x) {
      const glm::dvec3 d = layout.texel_dir(x, y);
      env.image.set(x, y,
                    glm::vec3(kC + kSy * (d.y > 0 ? 1.0 : -1.0) + s_x * (d.x > 0 ? 1.0 : -1.0)));
    }
  return env;
}

// The sphere's world-frame normal and reflected direction at a pixel well inside it.
struct Surface {
  glm::dvec3 n, r;
};
std::optional<Surface> surface_at(const SphereScene& s, int x, int y, const glm::dquat& world) {
  if (s.inside(x, y) != 1) return std::nullopt;
  const glm::dvec3 p = *ray_sphere(s.cam, x, y, s.centre, SphereScene::kRadius).point;
  const glm::dvec3 n = glm::normalize(p - s.centre);  // camera = scene rotation here
  const glm::dvec3 v = glm::normalize(-p);            // towards the eye
  return Surface{world * n, world * glm::reflect(-v, n)};
}

glm::dvec3 eq6(glm::dvec3 d, glm::dvec3 up, glm::dvec3 down, glm::dvec2 occlusion) {
  const double a = 0.5 + 0.5 * d.y;
  return (a * up + (1.0 - a) * down) * glm::mix(occlusion.x, occlusion.y, a);
}

TEST(HemispherePriors, AreTheRoomsUpperAndLowerMeansAndItsLitAndDarkSides) {
  SphereScene s;
  const glm::dvec3 s_x(0.5, 0.4, 0.3);
  const EnvMap room = step_room(s_x);
  const glm::vec3 up(kC + kSy), down(kC - kSy), lit(kC + s_x), dark(kC - s_x);
  // Light and shadow are luminances as the renderer takes them (Rec. 709, common/image.hpp).
  const auto expect_priors = [&](const HemispherePriors& h) {
    for (int ch = 0; ch < 3; ++ch) {
      EXPECT_NEAR(h.upper[ch], up[ch], 0.01 * up[ch]);
      EXPECT_NEAR(h.lower[ch], down[ch], 0.01 * down[ch]);
    }
    EXPECT_NEAR(h.light, luminance(lit), 0.01 * luminance(lit));
    EXPECT_NEAR(h.shadow, luminance(dark), 0.01 * luminance(dark));
  };
  s.r.set_sh(sh_project(room, 8));  // the live SH, as arlightd sends it
  expect_priors(s.r.hemisphere_priors());

  // With a map set, from its irradiance map (here the exact one).
  const EnvLayout layout = EnvLayout::for_size(Projection::Cube, 32);
  EnvMap irradiance(layout);
  for (int y = 0; y < layout.height(); ++y)
    for (int x = 0; x < layout.width(); ++x) {
      const glm::dvec3 n = layout.texel_dir(x, y);
      irradiance.image.set(x, y, glm::vec3(kC + kSy * n.y + s_x * n.x));
    }
  s.r.set_maps({1.0}, {irradiance});
  expect_priors(s.r.hemisphere_priors());
}

// Eq. 6 on every pixel of the sphere, with the scene turned against the world: a blend by the
// camera's (scene's) up instead of the world's would be off by up to |c_u - c_l|.
TEST(HemisphereShading, TwoColourRoomGivesEquation6ByTheWorldsUpAxis) {
  SphereScene s;
  const EnvMap room = step_room(glm::dvec3(0.0));
  s.r.set_sh(sh_project(room, 8));
  const glm::dquat world = glm::angleAxis(1.1, glm::normalize(glm::dvec3(0.7, 0.2, -0.4)));
  s.r.set_world_from_scene(world);
  s.r.set_shading(Shading::Hemisphere);
  const glm::dvec3 up = kC + kSy, down = kC - kSy;
  Material m;
  m.kd = glm::vec3(0.8f, 0.6f, 0.4f), m.ks = glm::vec3(0.2f, 0.3f, 0.1f);
  const HdrReadback hdr = s.render(m);
  // For this room eq. 6 is the exact irradiance: image-based shading of the diffuse part
  // agrees (the specular part differs: the maps are sharper than two colours).
  s.r.set_shading(Shading::ImageBased);
  Material diffuse;
  diffuse.kd = m.kd, diffuse.ks = glm::vec3(0.0f);
  const HdrReadback ibl = s.render(diffuse);
  int checked = 0;
  double worst = 0, worst_ibl = 0;
  for (int y = 0; y < H; y += 2)
    for (int x = 0; x < W; x += 2) {
      const auto hit = surface_at(s, x, y, world);
      if (!hit) continue;
      const glm::dvec3 ld = eq6(hit->n, up, down, {1, 1}), ls = eq6(hit->r, up, down, {1, 1});
      const glm::dvec3 want = glm::dvec3(m.kd) * ld + glm::dvec3(m.ks) * ls;
      const glm::dvec3 got = hdr.radiance.at(x, y);
      const glm::dvec3 got_ibl = ibl.radiance.at(x, y);
      for (int ch = 0; ch < 3; ++ch) {
        worst = std::max(worst, std::abs(got[ch] - want[ch]) / want[ch]);
        worst_ibl =
            std::max(worst_ibl, std::abs(got_ibl[ch] - m.kd[ch] * ld[ch]) / (m.kd[ch] * ld[ch]));
      }
      ++checked;
    }
  EXPECT_GT(checked, 1000);
  EXPECT_LT(worst, 0.015) << "eq. 6 (hemisphere shading against the formula)";
  EXPECT_LT(worst_ibl, 0.03) << "the irradiance maps against eq. 6";
}

// Hemisphere occlusion: the same blend times a grey factor from shadow / light (down) to 1 (up).
TEST(HemisphereShading, OcclusionDarkensTowardsTheGroundByTheDarkOverTheLitSide) {
  SphereScene s;
  const glm::dvec3 s_x(0.5, 0.4, 0.3);
  s.r.set_sh(sh_project(step_room(s_x), 8));
  const glm::dquat world = glm::angleAxis(-0.6, glm::normalize(glm::dvec3(1.0, 0.1, 0.3)));
  s.r.set_world_from_scene(world);
  const glm::dvec3 up = kC + kSy, down = kC - kSy;
  const double ratio = luminance(kC - s_x) / luminance(kC + s_x);
  Material m;
  m.kd = glm::vec3(1.0f), m.ks = glm::vec3(0.0f);
  s.r.set_shading(Shading::Hemisphere);
  const HdrReadback plain = s.render(m);
  s.r.set_shading(Shading::HemisphereOcclusion);
  const HdrReadback occluded = s.render(m);
  EXPECT_LT(ratio, 0.5);  // the occlusion matters in this room
  int checked = 0;
  double worst = 0;
  for (int y = 0; y < H; y += 2)
    for (int x = 0; x < W; x += 2) {
      const auto hit = surface_at(s, x, y, world);
      if (!hit) continue;
      const glm::dvec3 want = eq6(hit->n, up, down, {ratio, 1.0});
      const glm::dvec3 got = occluded.radiance.at(x, y);
      for (int ch = 0; ch < 3; ++ch)
        worst = std::max(worst, std::abs(got[ch] - want[ch]) / want[ch]);
      EXPECT_LE(lum(occluded.radiance.at(x, y)), lum(plain.radiance.at(x, y)) * 1.002f);
      ++checked;
    }
  EXPECT_GT(checked, 1000);
  EXPECT_LT(worst, 0.015);
}

}  // namespace
}  // namespace arlight::render
