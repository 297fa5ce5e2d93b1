// Colour priors and colour correction (dissertation §5.1, §5.6): eq. 11a's space, the room's
// priors from its horizontal regions, the model's from the texels its UVs cover, and the
// compositing options: colour matching (eq. 11b) gives the object the room's statistics,
// brightness keeps it within the room's darkest and lightest side.
#include <algorithm>

#include "render_fixtures.hpp"

namespace arlight::render {
namespace {

using namespace testing;

constexpr int W = SphereScene::W, H = SphereScene::H;

// The dissertation's printed inverse (eq. 11a), minus signs restored.
const glm::mat3 kPrintedInverse = glm::transpose(glm::mat3(0.5773f, 0.2621f, 5.6947f,   //
                                                           0.5774f, 0.6072f, -2.5444f,  //
                                                           0.5832f, -1.0627f, 0.2073f));

TEST(ColourSpace, TheInverseUndoesTheForwardMatrixAndGreysHaveNoColour) {
  const glm::mat3 round_trip = rgb_from_lab() * lab_from_rgb();
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) EXPECT_NEAR(round_trip[i][j], i == j ? 1.0f : 0.0f, 1e-5f);
  // The printed inverse is the same to its rounding.
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) EXPECT_NEAR(kPrintedInverse[i][j], rgb_from_lab()[i][j], 1e-3f);
  // Opponent axes: a grey has (almost) no alpha or beta; with the print's lost minus signs it
  // would have alpha 1.29. Blue is -alpha (yellow-blue), red +beta (red-green).
  const glm::vec3 grey = lab_from_rgb() * glm::vec3(0.5f);
  EXPECT_NEAR(grey[1], 0.0f, 0.005f);
  EXPECT_NEAR(grey[2], 0.0f, 0.005f);
  EXPECT_LT((lab_from_rgb() * glm::vec3(0, 0, 1))[1], -0.5f);
  EXPECT_GT((lab_from_rgb() * glm::vec3(1, 0, 0))[2], 0.1f);
}

// A room whose four sides, top and bottom are uniform colours: the priors are the four sides'
// (equal solid angles), whatever the top and bottom hold.
EnvMap six_sided_room(const std::array<glm::vec3, 4>& sides, glm::vec3 top_bottom) {
  const EnvLayout layout = EnvLayout::for_size(Projection::Cube, 32);
  EnvMap env(layout);
  for (int y = 0; y < layout.height(); ++y)
    for (int x = 0; x < layout.width(); ++x) {
      const glm::dvec3 d = layout.texel_dir(x, y);
      glm::vec3 c = top_bottom;
      if (std::abs(d.y) <= std::max(std::abs(d.x), std::abs(d.z)))
        c = sides[std::abs(d.z) >= std::abs(d.x) ? (d.z < 0 ? 0 : 2) : (d.x > 0 ? 1 : 3)];
      env.image.set(x, y, c);
    }
  return env;
}

TEST(ColourPriors, TheRoomsAreItsFourSidesMeanAndDeviation) {
  const std::array<glm::vec3, 4> sides = {glm::vec3(0.2f, 0.3f, 0.4f), glm::vec3(0.6f, 0.5f, 0.2f),
                                          glm::vec3(0.1f, 0.1f, 0.1f), glm::vec3(0.4f, 0.4f, 0.5f)};
  const EnvironmentPriors p = environment_priors(six_sided_room(sides, glm::vec3(50.0f)));
  glm::dvec3 mean(0.0), mean2(0.0);
  float lo = 1e9f, hi = 0.0f, grey = 0.0f;
  for (const glm::vec3& c : sides) {
    const glm::dvec3 lab(lab_from_rgb() * c);
    mean += lab / 4.0, mean2 += lab * lab / 4.0;
    lo = std::min(lo, luminance(c)), hi = std::max(hi, luminance(c)), grey += luminance(c) / 4;
  }
  const glm::dvec3 sd = glm::sqrt(mean2 - mean * mean);
  for (int k = 0; k < 3; ++k) {
    EXPECT_NEAR(p.lab.mean[k], mean[k], 1e-3) << k;
    EXPECT_NEAR(p.lab.sd[k], sd[k], 1e-3) << k;
  }
  EXPECT_NEAR(p.grey_low, lo, 1e-4f);
  EXPECT_NEAR(p.grey_high, hi, 1e-4f);
  EXPECT_NEAR(p.grey_mean, grey, 1e-4f);
}

// A quad whose UVs cover the left half of its texture: the right half is the dissertation's
// "green screen", and the model's priors never see it.
TEST(ColourPriors, TheModelsCountOnlyTheTexelsItsUvsCover) {
  Mesh quad;
  quad.positions = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  quad.normals.assign(4, glm::vec3(0, 0, 1));
  quad.uvs = {{0.0f, 1.0f}, {0.5f, 1.0f}, {0.5f, 0.0f}, {0.0f, 0.0f}};
  quad.indices = {0, 1, 2, 0, 2, 3};
  const std::vector<std::uint8_t> covered = uv_coverage(quad, 64, 32);
  ASSERT_EQ(covered.size(), 64u * 32u);
  for (int y = 0; y < 32; ++y)
    for (int x = 0; x < 64; ++x)
      ASSERT_EQ(covered[std::size_t(y) * 64 + x], x < 32) << x << "," << y;

  // Linear RGB texels: a red gradient where the UVs are, pure green elsewhere.
  std::vector<float> texels(64 * 32 * 3);
  for (int y = 0; y < 32; ++y)
    for (int x = 0; x < 64; ++x) {
      const glm::vec3 c = x < 32 ? glm::vec3(0.3f + 0.02f * x, 0.1f, 0.05f) : glm::vec3(0, 1, 0);
      for (int k = 0; k < 3; ++k) texels[(std::size_t(y) * 64 + x) * 3 + k] = c[k];
    }
  Material m;
  m.kd = glm::vec3(0.5f);
  m.albedo = make_texture(64, 32, 3, texels);
  const std::optional<ColourStats> model = model_priors(quad, m);
  ASSERT_TRUE(model);
  glm::dvec3 mean(0.0), mean2(0.0);
  for (int x = 0; x < 32; ++x) {
    const glm::dvec3 lab(lab_from_rgb() * (0.5f * glm::vec3(0.3f + 0.02f * x, 0.1f, 0.05f)));
    mean += lab / 32.0, mean2 += lab * lab / 32.0;
  }
  for (int k = 0; k < 3; ++k) {
    EXPECT_NEAR(model->mean[k], mean[k], 1e-4) << k;
    EXPECT_NEAR(model->sd[k], std::sqrt(mean2[k] - mean[k] * mean[k]), 1e-4) << k;
  }
  quad.uvs.clear();  // no UVs: kd alone
  EXPECT_NEAR(model_priors(quad, m)->mean[0], (lab_from_rgb() * m.kd)[0], 1e-6);
}

// The sphere under a room with a colour gradient, composited with Linear tone mapping (codes
// are the camera's linear values): colour matching gives its pixels the room's mean and
// deviation in l alpha beta; without it they are far off.
struct MatchScene : SphereScene {
  MatchScene() {
    const std::array<glm::vec3, 4> sides = {
        glm::vec3(0.25f, 0.35f, 0.55f), glm::vec3(0.45f, 0.4f, 0.3f), glm::vec3(0.2f, 0.25f, 0.3f),
        glm::vec3(0.35f, 0.45f, 0.5f)};
    const EnvMap room = six_sided_room(sides, glm::vec3(0.3f));
    r.set_maps({1.0, 64.0}, {room, room});
    m.kd = glm::vec3(0.9f, 0.5f, 0.3f), m.ks = glm::vec3(0.1f), m.shininess = 64;
  }
  Material m;

  // The composite's object pixels (linear, from the Linear tone mapping's codes).
  std::vector<glm::vec3> object_pixels(ColourCorrection colour) {
    r.begin_frame();
    r.draw(sphere, m, glm::mat4(1.0f));
    cv::Mat out;
    ToneMapping tone{ToneMode::Linear, 1.0, 1.0};
    tone.colour = colour;
    composite(r, cv::Mat(H, W, CV_8UC3, cv::Scalar(0, 0, 0)), tone, out);
    const std::vector<std::uint8_t> mask = r.read_hdr().mask;
    std::vector<glm::vec3> px;
    for (int y = 0; y < H; ++y)
      for (int x = 0; x < W; ++x)
        if (mask[std::size_t(y) * W + x] && inside(x, y) == 1)
          px.push_back(bgr_at(out, x, y) / 255.0f);
    return px;
  }
};

ColourStats lab_stats(const std::vector<glm::vec3>& px) {
  glm::dvec3 mean(0.0), mean2(0.0);
  for (const glm::vec3& c : px) {
    const glm::dvec3 lab(lab_from_rgb() * c);
    mean += lab, mean2 += lab * lab;
  }
  mean /= double(px.size()), mean2 /= double(px.size());
  return {glm::vec3(mean), glm::vec3(glm::sqrt(glm::max(mean2 - mean * mean, glm::dvec3(0.0))))};
}

TEST(ColourCorrection, MatchingGivesTheObjectTheRoomsMeanAndDeviation) {
  MatchScene s;
  const EnvironmentPriors room = s.r.environment_priors();
  const ColourStats before = lab_stats(s.object_pixels(ColourCorrection::None));
  const ColourStats after = lab_stats(s.object_pixels(ColourCorrection::Match));
  for (int k = 0; k < 3; ++k) {
    // Codes quantise to 1/255: the deviation of a channel near 0 is held within that.
    EXPECT_NEAR(after.mean[k], room.lab.mean[k], 0.01 + 0.02 * std::abs(room.lab.mean[k])) << k;
    EXPECT_NEAR(after.sd[k], room.lab.sd[k], 0.004 + 0.05 * room.lab.sd[k]) << k;
  }
  // Unmatched, the orange sphere is far from the bluish room's mean colour.
  EXPECT_GT(glm::length(before.mean - room.lab.mean),
            10.0f * glm::length(after.mean - room.lab.mean));
}

TEST(ColourCorrection, BrightnessKeepsTheObjectWithinTheRoomsDarkestAndLightestSide) {
  MatchScene s;
  const EnvironmentPriors room = s.r.environment_priors();
  const std::vector<glm::vec3> before = s.object_pixels(ColourCorrection::None);
  const std::vector<glm::vec3> after = s.object_pixels(ColourCorrection::Brightness);
  ASSERT_EQ(before.size(), after.size());
  const auto luma = [](glm::vec3 c) { return glm::dot(c, glm::vec3(0.2126f, 0.7152f, 0.0722f)); };
  const float tol = 2.0f / 255.0f;
  for (std::size_t i = 0; i < after.size(); ++i) {
    const float y = luma(before[i]);
    // Linear tone mapping (exposure 1): the priors as displayed are the greys themselves.
    EXPECT_NEAR(luma(after[i]), room.grey_low + (room.grey_high - room.grey_low) * y, tol);
    // The colour is kept: the channels keep their ratios (where they are well above a code).
    if (before[i].g > 0.1f && after[i].g > 0.1f) {
      const float ratio = before[i].r / before[i].g;
      EXPECT_NEAR(after[i].r / after[i].g, ratio, 0.05f * ratio);
    }
  }
}

}  // namespace
}  // namespace arlight::render
