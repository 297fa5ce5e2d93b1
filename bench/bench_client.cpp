// The thin client's per-frame work at 1280x720 with the bunny, headless on Mesa's CPU renderer
// (llvmpipe): marker tracking, rendering (image-based lighting from a map set, shadow catcher)
// and camera-matched tone mapping + compositing with readback — what arlight-client does for
// every frame, without the network (the lighting is computed here once, as arlightd would send
// it). Frames come from a simulated 1280x720 orbit around a marker in venice (arlight-sim).
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <vector>

#include "arlight/hdr_io.hpp"
#include "arlight/lighting.hpp"
#include "arlight/render.hpp"
#include "arlight/resample.hpp"
#include "arlight/sh.hpp"
#include "arlight/source.hpp"
#include "arlight/track.hpp"

using namespace arlight;
namespace fs = std::filesystem;

namespace {

struct ClientFixture {
  std::vector<source::SourceFrame> frames;
  CameraIntrinsics camera;
  std::vector<double> shininess = {1, 10, 20, 40, 80, 160, 320, 1280};
  std::vector<EnvMap> maps;
  DominantLight light;
};

// Simulates the recording once per process (a few seconds) and computes venice's map set.
const ClientFixture& fixture() {
  static const std::unique_ptr<ClientFixture> f = [] {
    auto fx = std::make_unique<ClientFixture>();
    const fs::path rec = fs::temp_directory_path() / "arlight_bench_client_720p";
    const std::string probe = std::string(ARLIGHT_SOURCE_DIR) + "/data/probes/venice.exr";
    if (!fs::exists(rec / "recording.json")) {
      const std::string cmd = std::string(ARLIGHT_SIM_EXE) + " --env " + probe + " --out " +
                              rec.string() +
                              " --frames 32 --size 1280x720 --trajectory orbit --marker 7,0.2"
                              " --seed 3 > /dev/null 2>&1";
      if (std::system(cmd.c_str()) != 0) throw std::runtime_error("arlight-sim failed: " + cmd);
    }
    source::ReplaySource src(rec);
    fx->camera = src.intrinsics();
    while (auto frame = src.next()) fx->frames.push_back(std::move(*frame));
    const EnvMap env = load_envmap(probe).env;
    const EnvLayout layout = EnvLayout::for_size(Projection::AngleMap, 128);
    fx->maps = lighting::compute_maps(resample(env, layout), fx->shininess, layout,
                                      lighting::parse_method("auto"))
                   .maps;
    fx->light = sh_dominant_light(sh_project(env, 2));
    return fx;
  }();
  return *f;
}

void BM_ClientFrame(benchmark::State& state, bool shadow) {
  const ClientFixture& fx = fixture();
  render::GlContext gl = render::GlContext::headless();
  render::Renderer renderer(fx.camera.width, fx.camera.height);
  renderer.set_maps(fx.shininess, fx.maps);
  const render::Mesh mesh =
      render::load_gltf(std::string(ARLIGHT_SOURCE_DIR) + "/data/models/bunny.glb");
  const render::GpuMesh gpu_mesh(mesh);
  const glm::mat4 model = render::standing_on_marker(mesh.bounds, 0.3f);
  render::Material material;
  material.kd = glm::vec3(0.7f), material.ks = glm::vec3(0.3f), material.shininess = 80;
  track::MarkerTracker tracker(fx.camera, {"DICT_4X4_50", 7, 0.2});
  track::WorldFromMarker world_from_marker;
  render::ToneMapping tone;
  cv::Mat out;
  std::vector<double> track_ms, render_ms, tonemap_ms, total_ms;
  std::size_t k = 0, drawn = 0;
  for (auto _ : state) {
    const source::SourceFrame& f = fx.frames[k++ % fx.frames.size()];
    const auto t0 = std::chrono::steady_clock::now();
    const track::TrackResult tr = tracker.track(f.bgr, f.timestamp);
    if (tr.tracked && f.orientation)
      world_from_marker.add(f.timestamp, *f.orientation, tr.raw.orientation);
    const double t_track =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    renderer.begin_frame();
    if (tr.tracked && world_from_marker.world_from_marker()) {
      renderer.set_camera(fx.camera, track::view_matrix(tr.smoothed));
      renderer.set_world_from_scene(*world_from_marker.world_from_marker());
      renderer.set_shadow({.enabled = shadow,
                           .light_direction = fx.light.direction,
                           .light_colour = fx.light.colour});
      renderer.draw(gpu_mesh, material, model);
      ++drawn;
    }
    tone.exposure = f.exposure, tone.gain = f.gain;
    renderer.composite(f.bgr, tone, out);
    const render::FrameTimings& t = renderer.timings();
    track_ms.push_back(t_track);
    render_ms.push_back(t.render_ms);
    tonemap_ms.push_back(t.tonemap_ms + t.readback_ms);
    total_ms.push_back(t_track + t.render_ms + t.tonemap_ms + t.readback_ms);
  }
  const auto median = [](std::vector<double> v) {
    std::sort(v.begin(), v.end());
    return v.empty() ? 0.0 : v[v.size() / 2];
  };
  state.counters["tracking_ms"] = median(track_ms);
  state.counters["render_ms"] = median(render_ms);
  state.counters["tonemap_ms"] = median(tonemap_ms);
  state.counters["median_ms"] = median(total_ms);
  state.counters["fps"] = 1000.0 / std::max(1e-9, median(total_ms));
  state.counters["drawn_pct"] = 100.0 * double(drawn) / double(std::max<std::size_t>(1, k));
}

}  // namespace

BENCHMARK_CAPTURE(BM_ClientFrame, bunny_720p, true)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(96)
    ->UseRealTime();
BENCHMARK_CAPTURE(BM_ClientFrame, bunny_720p_no_shadow, false)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(96)
    ->UseRealTime();
