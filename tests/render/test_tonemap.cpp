// Tone mapping over a sphere whose luminance varies: Reinhard (thesis Alg. 5.5, fixed) uses the
// log-average luminance of the masked pixels only; Linear clamps. Checked pixel by pixel
// against the formulas applied to the HDR target.
#include "render_fixtures.hpp"

namespace arlight::render {
namespace {

using namespace testing;

constexpr int W = 160, H = 120;

float srgb(float v) {
  v = std::clamp(v, 0.0f, 1.0f);
  return v <= 0.0031308f ? 12.92f * v : 1.055f * std::pow(v, 1.0f / 2.4f) - 0.055f;
}

struct GradientSphere {
  GradientSphere() {
    const CameraIntrinsics k = CameraIntrinsics::from_fov(W, H, 40.0);
    r.set_camera(k, camera_on_z(4.0));
    // A strongly varying environment: luminance over the sphere spans ~2 decades.
    const EnvLayout layout = EnvLayout::for_size(Projection::LatLong, 32);
    EnvMap env(layout);
    for (int y = 0; y < layout.height(); ++y)
      for (int x = 0; x < layout.width(); ++x) {
        const glm::dvec3 d = layout.texel_dir(x, y);
        env.image.set(x, y, glm::vec3(float(std::exp(3.0 * d.y + 1.5 * d.x))));
      }
    r.set_maps({1.0, 32.0}, {env, env});
    Material m;
    m.kd = glm::vec3(0.7f, 0.5f, 0.3f);
    m.ks = glm::vec3(0.1f);
    r.begin_frame();
    r.draw(sphere, m, glm::mat4(1.0f));
    hdr = r.read_hdr();
  }
  GlContext& ctx = context();
  Renderer r{W, H};
  GpuMesh sphere{make_sphere(1.0f, 48, 96)};
  HdrReadback hdr;
};

TEST(Reinhard, LogAverageOverTheMaskOnlyAndPerPixelCodes) {
  GradientSphere s;
  // The log-average of the virtual pixels, by hand.
  double log_sum = 0, sum = 0;
  int n = 0;
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x)
      if (s.hdr.mask[std::size_t(y) * W + x]) {
        const double l = lum(s.hdr.radiance.at(x, y));
        log_sum += std::log(std::max(l, 1e-6)), sum += l, ++n;
      }
  ASSERT_GT(n, 5000);
  const double log_avg = std::exp(log_sum / n);
  // The test can tell a log-average from an arithmetic one (and from the thesis's mask mean).
  ASSERT_GT(sum / n / log_avg, 1.1);

  const cv::Mat frame = noise_frame(W, H);
  ToneMapping tone;
  tone.mode = ToneMode::Reinhard, tone.key = 0.3f, tone.white = 1.5f;
  cv::Mat out;
  composite(s.r, frame, tone, out);
  EXPECT_NEAR(s.r.last_log_average(), log_avg, 1e-3 * log_avg);
  int off = 0;
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const glm::vec3 got = bgr_at(out, x, y);
      if (!s.hdr.mask[std::size_t(y) * W + x]) {
        ASSERT_EQ(got, bgr_at(frame, x, y));
        continue;
      }
      const glm::vec3 c = s.hdr.radiance.at(x, y);
      const float lw = lum(c), l = float(tone.key * lw / log_avg);
      const float ld = l * (1.0f + l / (tone.white * tone.white)) / (1.0f + l);
      for (int ch = 0; ch < 3; ++ch) {
        const long want = std::lround(255.0f * srgb(c[ch] * ld / lw));
        ASSERT_NEAR(got[ch], want, 1.0) << x << "," << y << " channel " << ch;
        off += got[ch] != float(want);
      }
    }
  EXPECT_LT(off, n / 50);
}

TEST(Linear, ClampsExposedRadiance) {
  GradientSphere s;
  const cv::Mat frame = noise_frame(W, H);
  ToneMapping tone;
  tone.mode = ToneMode::Linear, tone.exposure = 0.05, tone.gain = 1.5;
  cv::Mat out;
  composite(s.r, frame, tone, out);
  int clipped = 0;
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      if (!s.hdr.mask[std::size_t(y) * W + x]) continue;
      for (int ch = 0; ch < 3; ++ch) {
        const float v = s.hdr.radiance.at(x, y)[ch] * float(tone.exposure * tone.gain);
        ASSERT_NEAR(bgr_at(out, x, y)[ch], std::lround(255.0f * std::clamp(v, 0.0f, 1.0f)), 1.0);
        clipped += v > 1.0f;
      }
    }
  EXPECT_GT(clipped, 0);  // both regimes are exercised
}

}  // namespace
}  // namespace arlight::render
