// Per-frame cost at 1280x720 with the bunny (render + tone map + readback), printed for
// bench/RESULTS.md; no timed assertions (benchmarks carry speed targets, DESIGN.md).
#include <chrono>
#include <cstdio>
#include <glm/gtc/matrix_transform.hpp>

#include "render_fixtures.hpp"

namespace arlight::render {
namespace {

using namespace testing;

TEST(Timing, BunnyAt1280x720) {
  GlContext& ctx = context();
  constexpr int W = 1280, H = 720;
  Renderer r(W, H);
  const Mesh mesh = load_gltf(std::filesystem::path(ARLIGHT_ASSETS_DIR) / "models/bunny.glb");
  GpuMesh bunny(mesh);
  // Maps like a daemon's set: 128 x 256 lat-long, irradiance + 3 reflection maps.
  const EnvLayout layout = EnvLayout::for_size(Projection::LatLong, 128);
  std::vector<EnvMap> maps;
  for (int k = 0; k < 4; ++k) {
    EnvMap env(layout);
    for (int y = 0; y < layout.height(); ++y)
      for (int x = 0; x < layout.width(); ++x)
        env.image.set(x, y, glm::vec3(float(std::exp(2.0 * layout.texel_dir(x, y).y) / (k + 1))));
    maps.push_back(std::move(env));
  }
  r.set_maps({1, 16, 64, 256}, maps);
  // The bunny (about 1.8 units wide) standing on the marker, 3 units from a tilted camera.
  const CameraIntrinsics k = CameraIntrinsics::from_fov(W, H, 60.0);
  const glm::dmat4 view = glm::translate(glm::dmat4(1.0), glm::dvec3(0, -0.2, -3.0)) *
                          glm::rotate(glm::dmat4(1.0), glm::radians(25.0), glm::dvec3(1, 0, 0));
  r.set_camera(k, view);
  Material m;
  m.kd = glm::vec3(0.6f, 0.5f, 0.4f);
  m.ks = glm::vec3(0.2f);
  m.shininess = 40.0f;
  const cv::Mat frame = noise_frame(W, H);
  cv::Mat out;
  for (ToneMode mode : {ToneMode::CameraMatched, ToneMode::Reinhard}) {
    FrameTimings sum;
    const int frames = 20;
    for (int f = -2; f < frames; ++f) {  // two warm-up frames
      const auto t0 = std::chrono::steady_clock::now();
      r.begin_frame();
      const glm::mat4 model = glm::rotate(glm::mat4(1.0f), 0.05f * f, glm::vec3(0, 1, 0));
      r.draw(bunny, m, model);
      ToneMapping tone;
      tone.mode = mode, tone.exposure = 1.0 / 60.0, tone.gain = 4.0;
      composite(r, frame, tone, out);
      (void)t0;
      if (f < 0) continue;
      sum.render_ms += r.timings().render_ms / frames;
      sum.tonemap_ms += r.timings().tonemap_ms / frames;
      sum.readback_ms += r.timings().readback_ms / frames;
    }
    std::printf("[timing] %s, bunny (%zu triangles), %dx%d, %s: render %.2f ms, tone map %.2f ms, "
                "readback %.2f ms, total %.2f ms per frame\n",
                ctx.renderer().c_str(), mesh.triangle_count(), W, H,
                mode == ToneMode::CameraMatched ? "camera-matched" : "Reinhard", sum.render_ms,
                sum.tonemap_ms, sum.readback_ms, sum.total());
    RecordProperty(mode == ToneMode::CameraMatched ? "camera_matched_ms" : "reinhard_ms",
                   std::to_string(sum.total()));
  }
  // The bunny is on screen and the frame around it untouched.
  const HdrReadback hdr = r.read_hdr();
  std::size_t covered = 0;
  for (auto v : hdr.mask) covered += v;
  EXPECT_GT(covered, std::size_t(W) * H / 20);
  EXPECT_EQ(bgr_at(out, 0, 0), bgr_at(frame, 0, 0));
}

}  // namespace
}  // namespace arlight::render
