// Normal mapping (thesis Alg. 5.3/5.4) and light mapping (Alg. 5.2) on a sphere whose tangent
// frame is known analytically: tangent along +u = normalize(Y x n), bitangent n x t.
#include "render_fixtures.hpp"

namespace arlight::render {
namespace {

using namespace testing;

constexpr int W = SphereScene::W, H = SphereScene::H;

// An irradiance/reflection map set where every map is L(d) = a + g.d (grey).
void set_gradient_maps(Renderer& r, double a, glm::dvec3 g) {
  const EnvLayout layout = EnvLayout::for_size(Projection::LatLong, 64);
  EnvMap env(layout);
  for (int y = 0; y < layout.height(); ++y)
    for (int x = 0; x < layout.width(); ++x)
      env.image.set(x, y, glm::vec3(float(a + glm::dot(g, layout.texel_dir(x, y)))));
  r.set_maps({1.0, 64.0}, {env, env});
}

// The finer sphere: normal-map gradients need a smooth interpolated tangent frame.
struct Scene : SphereScene {
  Scene() : SphereScene(64, 128) {}
};

TEST(NormalMap, FlatMapLeavesThePixelsUnchanged) {
  Scene s;
  set_gradient_maps(s.r, 2.0, {0.7, 0.5, 0.3});
  Material m;
  m.kd = glm::vec3(0.9f, 0.6f, 0.3f);
  m.ks = glm::vec3(0.2f);
  const HdrReadback plain = s.render(m);
  m.normal_map = make_texture(cv::Mat(8, 8, CV_32FC3, cv::Scalar(1.0, 0.5, 0.5)), false);  // BGR
  const HdrReadback mapped = s.render(m);
  ASSERT_EQ(plain.mask, mapped.mask);
  int n = 0;
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      if (!plain.mask[std::size_t(y) * W + x]) continue;
      ++n;
      for (int ch = 0; ch < 3; ++ch)
        ASSERT_NEAR(mapped.radiance.at(x, y)[ch], plain.radiance.at(x, y)[ch],
                    2e-3 * plain.radiance.at(x, y)[ch]);
    }
  EXPECT_GT(n, 5000);
}

// A uniform 8-bit normal map tilted in tangent space: the diffuse shading at each pixel is the
// gradient environment at the perturbed normal M_TW * n_T (eq. 5.2, 5.3), which differs from the
// unperturbed shading by the predicted amount.
TEST(NormalMap, TiltedMapShadesWithThePerturbedNormal) {
  Scene s;
  const double a = 2.0;
  const glm::dvec3 g(0.6, 0.8, 0.3);
  set_gradient_maps(s.r, a, g);
  // Tilts towards +tangent (+u) and towards -bitangent (down the image), 30 degrees each.
  for (glm::dvec3 nt_wanted : {glm::dvec3(0.5, 0.0, 0.866), glm::dvec3(0.0, -0.5, 0.866)}) {
    const glm::dvec3 enc = glm::round((nt_wanted * 0.5 + 0.5) * 255.0);
    const glm::dvec3 nt = enc / 255.0 * 2.0 - 1.0;  // what the shader decodes (eq. 5.2)
    Material m;
    m.kd = glm::vec3(1.0f);
    m.normal_map = make_texture(cv::Mat(16, 16, CV_8UC3, cv::Scalar(enc.z, enc.y, enc.x)), false);
    const HdrReadback hdr = s.render(m);
    int checked = 0;
    double max_change = 0;
    for (int y = 0; y < H; y += 2)
      for (int x = 0; x < W; x += 2) {
        const auto p = s.hit(x, y);
        if (!p) continue;
        const glm::dvec3 n = glm::normalize(*p);
        if (n.z < 0.6) continue;  // stay away from the silhouette and the poles
        const glm::dvec3 t = glm::normalize(glm::cross(glm::dvec3(0, 1, 0), n));
        const glm::dvec3 b = glm::cross(n, t);
        const glm::dvec3 np = glm::normalize(t * nt.x + b * nt.y + n * nt.z);
        const double want = a + glm::dot(g, np), plain = a + glm::dot(g, n);
        ASSERT_NEAR(hdr.radiance.at(x, y).g, want, 0.01) << x << "," << y;
        max_change = std::max(max_change, std::abs(want - plain));
        ++checked;
      }
    EXPECT_GT(checked, 300);
    EXPECT_GT(max_change, 0.1);  // the test would see a missing or wrongly oriented tilt
  }
}

TEST(LightMap, DarkensTheDiffuseItCoversAndNotTheSpecular) {
  Scene s;
  const glm::vec3 c(1.0f, 2.0f, 4.0f);
  set_constant_maps(s.r, Projection::LatLong, c);
  Material m;
  m.kd = glm::vec3(0.5f, 0.5f, 0.25f);
  m.ks = glm::vec3(0.125f, 0.25f, 0.125f);
  // Black for u < 0.25 (the left half of the visible hemisphere, u = 0.25 faces the camera) and
  // for u > 0.75 (the back, so that the repeat-wrap neighbour of u = 0 is black too).
  cv::Mat lm(32, 64, CV_8UC3, cv::Scalar(255, 255, 255));
  lm.colRange(0, 16).setTo(cv::Scalar(0, 0, 0));
  lm.colRange(48, 64).setTo(cv::Scalar(0, 0, 0));
  m.light_map = make_texture(lm, false);
  const HdrReadback hdr = s.render(m);
  int dark = 0, lit = 0;
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const auto p = s.hit(x, y);
      if (!p || glm::normalize(*p).z < 0.5 || std::abs(glm::normalize(*p).y) > 0.6)
        continue;  // at grazing angles and near the poles the light map is minified (mipmapped)
      double u = std::atan2(p->z, -p->x) / (2.0 * M_PI);  // make_sphere's parameterisation
      if (u < 0) u += 1.0;
      const glm::vec3 got = hdr.radiance.at(x, y);
      glm::vec3 want;
      if (u < 0.25 - 0.03)
        want = m.ks * c, ++dark;
      else if (u > 0.25 + 0.03)
        want = m.kd * c + m.ks * c, ++lit;
      else
        continue;
      for (int ch = 0; ch < 3; ++ch)
        ASSERT_NEAR(got[ch], want[ch], 1e-3 * want[ch]) << x << "," << y;
    }
  EXPECT_GT(dark, 1000);
  EXPECT_GT(lit, 1000);
}

}  // namespace
}  // namespace arlight::render
