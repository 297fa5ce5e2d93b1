// IBL shading of a sphere (thesis Alg. 5.1): constant environments give kd*c (+ ks*c), through
// every projection and through the SH path; the mask is the sphere's silhouette; camera-matched
// tone mapping gives the response's codes and leaves the background alone.
#include "arlight/common/sh.hpp"
#include "render_fixtures.hpp"

namespace arlight::render {
namespace {

using namespace testing;

constexpr int W = SphereScene::W, H = SphereScene::H;
constexpr double kDist = SphereScene::kDist, kRadius = SphereScene::kRadius;

// Tolerance of a half-float value.
double half_tol(double v) { return std::abs(v) * 1e-3 + 1e-6; }

class ConstantEnvironment : public ::testing::TestWithParam<Projection> {};

TEST_P(ConstantEnvironment, DiffuseAndSpecularAreKdAndKsTimesTheRadiance) {
  SphereScene s;
  const glm::vec3 c(0.5f, 1.0f, 2.0f);
  set_constant_maps(s.r, GetParam(), c);
  EXPECT_EQ(s.r.lighting_source(), LightingSource::Maps);
  for (const glm::vec3 ks : {glm::vec3(0.0f), glm::vec3(0.25f, 0.5f, 0.125f)}) {
    Material m;
    m.kd = glm::vec3(0.2f, 0.4f, 0.6f);
    m.ks = ks;
    m.shininess = 50.0f;  // between the 16 and 256 maps: interpolated
    const HdrReadback hdr = s.render(m);
    const glm::vec3 want = m.kd * c + ks * c;
    int inside = 0, wrong_mask = 0, wrong_value = 0;
    for (int y = 0; y < H; ++y)
      for (int x = 0; x < W; ++x) {
        const int in = s.inside(x, y);
        const bool masked = hdr.mask[std::size_t(y) * W + x] != 0;
        if (in >= 0 && masked != (in == 1)) ++wrong_mask;
        if (!masked) {
          if (hdr.radiance.at(x, y) != glm::vec3(0.0f)) ++wrong_value;
          continue;
        }
        ++inside;
        const glm::vec3 got = hdr.radiance.at(x, y);
        for (int ch = 0; ch < 3; ++ch)
          if (std::abs(got[ch] - want[ch]) > half_tol(want[ch])) ++wrong_value;
      }
    EXPECT_EQ(wrong_mask, 0);
    EXPECT_EQ(wrong_value, 0) << "want " << want.x << " " << want.y << " " << want.z;
    // pi r^2 in pixels: fx * tan(asin(1/4)) is the silhouette radius.
    const double rad = s.k.fx * std::tan(std::asin(kRadius / kDist));
    EXPECT_NEAR(inside, M_PI * rad * rad, 2.0 * M_PI * rad);
  }
}

INSTANTIATE_TEST_SUITE_P(Projections, ConstantEnvironment,
                         ::testing::Values(Projection::AngleMap, Projection::LatLong,
                                           Projection::Cube),
                         [](const auto& info) { return std::string(projection_name(info.param)); });

TEST(ShLighting, ConstantEnvironmentMatchesTheMapsPath) {
  SphereScene s;
  const glm::vec3 c(0.75f, 1.5f, 3.0f);
  // The exact expansion of a constant: c_00 = c sqrt(4 pi) (Y_00 = 1 / sqrt(4 pi)), order 8 like
  // the daemon's live SH.
  ShCoeffs coeffs(8);
  coeffs.at(0, 0) = glm::dvec3(c) * std::sqrt(4.0 * M_PI);
  Material m;
  m.kd = glm::vec3(0.5f, 0.25f, 0.125f);
  m.ks = glm::vec3(0.1f);
  s.r.set_sh(coeffs);
  EXPECT_EQ(s.r.lighting_source(), LightingSource::Sh);
  const HdrReadback sh = s.render(m);
  set_constant_maps(s.r, Projection::LatLong, c);
  const HdrReadback maps = s.render(m);
  EXPECT_EQ(sh.mask, maps.mask);
  int compared = 0;
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      if (!maps.mask[std::size_t(y) * W + x]) continue;
      ++compared;
      for (int ch = 0; ch < 3; ++ch)
        ASSERT_NEAR(sh.radiance.at(x, y)[ch], maps.radiance.at(x, y)[ch],
                    2.0 * half_tol(maps.radiance.at(x, y)[ch]));
    }
  EXPECT_GT(compared, 5000);
  s.r.clear_maps();
  EXPECT_EQ(s.r.lighting_source(), LightingSource::Sh);
}

// A linear environment L(d) = a + b.d has SH in bands 0 and 1 only; its irradiance map (the
// cosine-weighted mean, band 1 scaled by 2/3, thesis eq. 2.33) is a + (2/3) b.n.
TEST(ShLighting, LinearEnvironmentGivesTheCosineConvolution) {
  SphereScene s;
  const glm::dvec3 a(1.0, 1.2, 1.4), b(0.6, -0.3, 0.5);  // per channel: a + b.d with b as a dir
  const EnvLayout layout = EnvLayout::for_size(Projection::LatLong, 64);
  EnvMap env(layout);
  const glm::dvec3 g(0.6, 0.8, -0.4);  // the gradient direction
  for (int y = 0; y < layout.height(); ++y)
    for (int x = 0; x < layout.width(); ++x)
      env.image.set(x, y, glm::vec3(a + b * glm::dot(g, layout.texel_dir(x, y))));
  s.r.set_sh(sh_project(env, 4));
  const glm::dquat world_from_scene =
      glm::angleAxis(0.7, glm::normalize(glm::dvec3(0.2, 1.0, 0.3)));
  s.r.set_world_from_scene(world_from_scene);
  Material m;
  m.kd = glm::vec3(1.0f);
  const HdrReadback hdr = s.render(m);
  int checked = 0;
  for (int y = 0; y < H; y += 3)
    for (int x = 0; x < W; x += 3) {
      if (s.inside(x, y) != 1) continue;
      const glm::dvec3 p = *ray_sphere(s.cam, x, y, s.centre, kRadius).point;
      const glm::dvec3 n_scene = glm::normalize(p - s.centre);  // camera = scene rotation here
      const glm::dvec3 n_world = world_from_scene * n_scene;
      const glm::dvec3 want = a + (2.0 / 3.0) * b * glm::dot(g, n_world);
      for (int ch = 0; ch < 3; ++ch)
        ASSERT_NEAR(hdr.radiance.at(x, y)[ch], want[ch], 0.01) << x << "," << y;
      ++checked;
    }
  EXPECT_GT(checked, 500);
}

TEST(CameraMatched, VirtualPixelsGoThroughExposureGainAndResponse) {
  SphereScene s;
  const glm::vec3 c(5.0f, 10.0f, 20.0f);
  set_constant_maps(s.r, Projection::Cube, c);
  Material m;
  m.kd = glm::vec3(0.2f, 0.4f, 0.6f);  // kd * c = (1, 4, 12): exact in half float
  const cv::Mat frame = noise_frame(W, H);
  for (const CameraResponse& resp : {CameraResponse::srgb(), CameraResponse::filmic()}) {
    s.r.set_response(resp);
    const HdrReadback hdr = s.render(m);
    ToneMapping tone;
    tone.exposure = 1.0 / 50.0, tone.gain = 2.0;
    cv::Mat out;
    composite(s.r, frame, tone, out);
    ASSERT_EQ(out.type(), CV_8UC3);
    int virt = 0, off_by_one = 0;
    for (int y = 0; y < H; ++y)
      for (int x = 0; x < W; ++x) {
        const glm::vec3 got = bgr_at(out, x, y);
        if (!hdr.mask[std::size_t(y) * W + x]) {
          ASSERT_EQ(got, bgr_at(frame, x, y)) << "background changed at " << x << "," << y;
          continue;
        }
        ++virt;
        for (int ch = 0; ch < 3; ++ch) {
          const float x_lin = hdr.radiance.at(x, y)[ch] * float(tone.exposure * tone.gain);
          const long want = std::lround(255.0 * resp.encode(x_lin, ch));
          ASSERT_NEAR(got[ch], want, 1.0) << resp.name() << " channel " << ch;
          off_by_one += got[ch] != float(want);
        }
      }
    EXPECT_GT(virt, 5000);
    EXPECT_LT(off_by_one, virt / 100) << "codes should match exactly almost everywhere";
    // The three channels' codes are far apart (0.04, 0.16, 0.48 linear): a swapped BGR/RGB
    // order or a missing exposure would be caught by the exact comparison above.
  }
}

TEST(Reinhard, ConstantSphereGivesTheHandComputedCode) {
  SphereScene s;
  const glm::vec3 c(2.0f, 4.0f, 8.0f);
  set_constant_maps(s.r, Projection::LatLong, c);
  Material m;
  m.kd = glm::vec3(0.5f, 0.25f, 0.5f);
  m.ks = glm::vec3(0.25f);
  const glm::vec3 cw = m.kd * c + m.ks * c;  // (1.5, 2, 6)
  const cv::Mat frame = noise_frame(W, H);
  for (auto [key, white] : {std::pair{0.18f, 2.0f}, std::pair{0.5f, 0.8f}}) {
    s.render(m);
    ToneMapping tone;
    tone.mode = ToneMode::Reinhard, tone.key = key, tone.white = white;
    cv::Mat out;
    composite(s.r, frame, tone, out);
    // Every virtual pixel has the same luminance, so the log-average is that luminance.
    const float lw = lum(cw);
    EXPECT_NEAR(s.r.last_log_average(), lw, lw * 1e-3);
    const float l = key;  // a * L_w / L_w-bar
    const float ld = l * (1.0f + l / (white * white)) / (1.0f + l);
    auto srgb = [](float v) {
      v = std::clamp(v, 0.0f, 1.0f);
      return v <= 0.0031308f ? 12.92f * v : 1.055f * std::pow(v, 1.0f / 2.4f) - 0.055f;
    };
    const glm::vec3 cd = cw * (ld / lw);
    const cv::Point centre(W / 2, H / 2);
    for (int ch = 0; ch < 3; ++ch)
      EXPECT_NEAR(bgr_at(out, centre.x, centre.y)[ch], std::lround(255.0f * srgb(cd[ch])), 1.0)
          << "key " << key << " white " << white << " channel " << ch;
    EXPECT_EQ(bgr_at(out, 2, 2), bgr_at(frame, 2, 2));
  }
}

}  // namespace
}  // namespace arlight::render
