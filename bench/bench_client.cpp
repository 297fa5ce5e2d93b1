// The thin client's per-frame work at 1280x720 with the bunny, headless on Mesa's CPU renderer
// (llvmpipe): marker tracking, rendering (image-based lighting from a map set, shadow catcher)
// and camera-matched tone mapping + compositing with readback — arlight_client_app's pipeline,
// as arlight-client runs it for every frame, without the network (the lighting is computed here
// once, as arlightd would send it). Frames come from a simulated 1280x720 orbit around a marker in
// venice (arlight-sim).
#include <benchmark/benchmark.h>
#include <tbb/info.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <map>
#include <memory>
#include <optional>
#include <vector>

#include "arlight/app/client_app.hpp"
#include "arlight/common/hdr_io.hpp"
#include "arlight/common/resample.hpp"
#include "arlight/common/sh.hpp"
#include "arlight/common/specular_lights.hpp"
#include "arlight/lighting/ggx.hpp"
#include "arlight/lighting/lighting.hpp"
#include "arlight/render/render.hpp"
#include "arlight/sim/simulate.hpp"
#include "arlight/source/source.hpp"
#include "arlight/track/track.hpp"

using namespace arlight;
namespace fs = std::filesystem;

namespace {

struct ClientFixture {
  std::vector<source::SourceFrame> frames;
  CameraIntrinsics camera;
  std::vector<double> shininess = {1, 10, 20, 40, 80, 160, 320, 1280};
  std::vector<EnvMap> maps;
  DominantLight light;
  // The GGX chain (face 128 -> 8) of venice less its brightest light (split_specular_lights at
  // a low threshold), and that light as kMaxSpecularLights lights of an eighth of its power each:
  // the same picture, with the shader's loop at its longest.
  lighting::GgxChain ggx;
  std::vector<SpecularLight> ggx_lights;
};

// Simulates the recording once per process (a few seconds) and computes venice's map set.
const ClientFixture& fixture() {
  static const std::unique_ptr<ClientFixture> f = [] {
    auto fx = std::make_unique<ClientFixture>();
    const fs::path rec = fs::temp_directory_path() / "arlight_bench_client_720p";
    const std::string probe = std::string(ARLIGHT_SOURCE_DIR) + "/data/probes/venice.exr";
    if (!fs::exists(rec / "recording.json")) {
      sim::SimOptions o;
      o.env = probe, o.out = rec;
      o.frames = 32, o.width = 1280, o.height = 720, o.seed = 3;
      o.trajectory = sim::TrajectoryKind::Orbit;
      o.marker = sim::MarkerSpec{7, 0.2, {0.0, -1.2, -0.8}};
      sim::simulate(o);
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
    const SpecularSplit split = split_specular_lights(env, {.threshold = 3.0, .max_radius = 1.5});
    fx->ggx = lighting::compute_ggx_chain(split.residual, {.face = 128, .min_face = 8});
    if (!split.lights.empty()) {
      SpecularLight part = split.lights.front();
      part.power /= float(kMaxSpecularLights);
      fx->ggx_lights.assign(kMaxSpecularLights, part);
    }
    return fx;
  }();
  return *f;
}

// The client's per-frame pipeline itself (arlight_client_app, as arlight-client runs it), with
// the lighting fixed instead of coming over the network.
void BM_ClientFrame(benchmark::State& state, bool shadow,
                    render::Shading shading = render::Shading::ImageBased,
                    std::optional<render::Refraction> glass = std::nullopt,
                    render::ColourCorrection colour = render::ColourCorrection::None,
                    int shadow_lights = 16, double target_fps = 0, int gold_lights = -1) {
  const ClientFixture& fx = fixture();
  render::GlContext gl = render::GlContext::headless();
  client_app::PipelineOptions options;
  options.camera = fx.camera;
  options.marker = {"DICT_4X4_50", 7, 0.2};
  options.object_height = 0.3;
  options.material.kd = glm::vec3(0.7f), options.material.ks = glm::vec3(0.3f);
  options.material.shininess = 80;
  options.shadow = shadow;
  options.shading = shading;
  options.colour = colour;
  options.shadow_lights = shadow_lights, options.target_fps = target_fps;
  if (glass) options.material = render::glass(1.5f, 1280.0f), options.refraction = *glass;
  // gold_lights >= 0: a gold bunny (glTF metallic-roughness) shaded with the GGX chain and that
  // many of the lights taken out of it (issue 51 §1's frame-time bound).
  auto ggx = std::make_shared<client::ReceivedMapSet>();
  if (gold_lights >= 0) {
    options.material = render::Material{};
    options.material.pbr = render::MetallicRoughness{};
    options.material.pbr->base_colour = glm::vec4(1.0f, 0.78f, 0.34f, 1.0f);
    options.material.pbr->metallic = 1.0f, options.material.pbr->roughness = 0.3f;
    ggx->kind = wire::MapKind::Ggx, ggx->complete = true;
    ggx->maps = fx.ggx.maps(), ggx->roughness = fx.ggx.roughness();
    const std::ptrdiff_t lights = std::min<std::ptrdiff_t>(gold_lights, std::ssize(fx.ggx_lights));
    ggx->lights.assign(fx.ggx_lights.begin(), fx.ggx_lights.begin() + lights);
    state.counters["ggx_lights"] = double(ggx->lights.size());
  }
  client_app::FramePipeline pipeline(
      options, render::load_gltf(std::string(ARLIGHT_SOURCE_DIR) + "/data/models/bunny.glb"));
  auto maps = std::make_shared<client::ReceivedMapSet>();
  maps->shininess = fx.shininess, maps->maps = fx.maps, maps->complete = true;
  client_app::Lighting fixed;
  fixed.maps = maps, fixed.maps_version = 1;
  fixed.dominant_direction = fx.light.direction, fixed.dominant_colour = fx.light.colour;
  if (gold_lights >= 0) fixed.ggx = ggx, fixed.ggx_version = 1;
  client_app::FixedLighting lighting(fixed);
  cv::Mat out;
  client_app::RunStats stats;
  std::size_t k = 0, drawn = 0;
  std::vector<double> refraction_ms, shadow_ms;
  for (auto _ : state) {
    const client_app::FrameReport r =
        pipeline.process(fx.frames[k++ % fx.frames.size()], lighting, out);
    stats.add(r, 0.0);
    drawn += r.drawn;
    refraction_ms.push_back(pipeline.renderer().timings().refraction_ms);
    if (r.drawn) shadow_ms.push_back(pipeline.renderer().timings().shadow_ms);
  }
  if (shadow) {
    state.counters["shadow_ms"] = client_app::median(shadow_ms);
    state.counters["shadow_lights"] = client_app::median(stats.shadow_lights);
  }
  if (glass == render::Refraction::LiveFrame)
    state.counters["refraction_ms"] = client_app::median(refraction_ms);
  state.counters["tracking_ms"] = client_app::median(stats.track_ms);
  state.counters["render_ms"] = client_app::median(stats.render_ms);
  state.counters["tonemap_ms"] = client_app::median(stats.tonemap_ms);
  state.counters["median_ms"] = client_app::median(stats.frame_ms);
  state.counters["fps"] = 1000.0 / std::max(1e-9, client_app::median(stats.frame_ms));
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
// Hemisphere shading (dissertation §5.4) instead of the maps: eq. 6, with and without occlusion.
BENCHMARK_CAPTURE(BM_ClientFrame, bunny_720p_hemisphere, true, render::Shading::Hemisphere)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(96)
    ->UseRealTime();
BENCHMARK_CAPTURE(BM_ClientFrame, bunny_720p_hemisphere_occlusion, true,
                  render::Shading::HemisphereOcclusion)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(96)
    ->UseRealTime();
// The bunny as glass (dissertation §5.5), seeing the maps or the camera frame through it.
BENCHMARK_CAPTURE(BM_ClientFrame, bunny_720p_glass_maps, true, render::Shading::ImageBased,
                  render::Refraction::Maps)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(96)
    ->UseRealTime();
BENCHMARK_CAPTURE(BM_ClientFrame, bunny_720p_glass_live, true, render::Shading::ImageBased,
                  render::Refraction::LiveFrame)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(96)
    ->UseRealTime();
// The dissertation's colour correction (§5.6): matching measures the object every frame.
BENCHMARK_CAPTURE(BM_ClientFrame, bunny_720p_colour_match, true, render::Shading::ImageBased,
                  std::nullopt, render::ColourCorrection::Match)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(96)
    ->UseRealTime();
BENCHMARK_CAPTURE(BM_ClientFrame, bunny_720p_colour_contrast, true, render::Shading::ImageBased,
                  std::nullopt, render::ColourCorrection::Contrast)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(96)
    ->UseRealTime();
// Soft shadows (tutorial §6): N hard shadows of the room's light clusters, fixed, and as many
// as hold 30 fps (the frame-rate control, §6.4; shadow_lights is the median it chose).
void BM_SoftShadowLights(benchmark::State& state) {
  BM_ClientFrame(state, true, render::Shading::ImageBased, std::nullopt,
                 render::ColourCorrection::None, int(state.range(0)), 0.0);
}
BENCHMARK(BM_SoftShadowLights)
    ->Arg(1)
    ->Arg(4)
    ->Arg(8)
    ->Arg(16)
    ->Arg(32)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(64)
    ->UseRealTime();
BENCHMARK_CAPTURE(BM_ClientFrame, bunny_720p_shadow_30fps, true, render::Shading::ImageBased,
                  std::nullopt, render::ColourCorrection::None, 32, 30.0)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(96)
    ->UseRealTime();
// A gold bunny with the GGX chain: the whole room in the chain (as before issue 51), and the
// chain's residual with one light and with the shader's most lights analytic.
BENCHMARK_CAPTURE(BM_ClientFrame, bunny_720p_gold, true, render::Shading::ImageBased, std::nullopt,
                  render::ColourCorrection::None, 16, 0.0, 0)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(96)
    ->UseRealTime();
BENCHMARK_CAPTURE(BM_ClientFrame, bunny_720p_gold_light, true, render::Shading::ImageBased,
                  std::nullopt, render::ColourCorrection::None, 16, 0.0, 1)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(96)
    ->UseRealTime();
BENCHMARK_CAPTURE(BM_ClientFrame, bunny_720p_gold_lights, true, render::Shading::ImageBased,
                  std::nullopt, render::ColourCorrection::None, 16, 0.0, kMaxSpecularLights)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(96)
    ->UseRealTime();

// The bunny's occlusion of itself baked with Embree on all cores (tutorial §6.1; what
// arlight-client does at model load), at the bundled 2,826 vertices and split 1 and 2 times
// (each triangle into four at its edges' midpoints: ~11 k and ~45 k vertices, beyond the
// original scan's 35,947), 1,024 directions per vertex (arlight-client's) and 2,048.
namespace {

render::Mesh split_triangles(const render::Mesh& in) {
  render::Mesh out;
  out.positions = in.positions;
  out.normals = in.normals;
  std::map<std::pair<std::uint32_t, std::uint32_t>, std::uint32_t> midpoints;
  const auto midpoint = [&](std::uint32_t a, std::uint32_t b) {
    const auto key = std::minmax(a, b);
    const auto [it, fresh] =
        midpoints.try_emplace({key.first, key.second}, std::uint32_t(out.positions.size()));
    if (fresh) {
      out.positions.push_back(0.5f * (in.positions[a] + in.positions[b]));
      out.normals.push_back(glm::normalize(in.normals[a] + in.normals[b]));
    }
    return it->second;
  };
  for (std::size_t t = 0; t < in.indices.size(); t += 3) {
    const std::uint32_t a = in.indices[t], b = in.indices[t + 1], c = in.indices[t + 2];
    const std::uint32_t ab = midpoint(a, b), bc = midpoint(b, c), ca = midpoint(c, a);
    out.indices.insert(out.indices.end(), {a, ab, ca, ab, b, bc, ca, bc, c, ab, bc, ca});
  }
  render::compute_bounds(out);
  return out;
}

void BM_BakeOcclusion(benchmark::State& state) {
  render::Mesh mesh = render::load_gltf(std::string(ARLIGHT_SOURCE_DIR) + "/data/models/bunny.glb");
  for (int i = 0; i < state.range(0); ++i) mesh = split_triangles(mesh);
  for (auto _ : state) {
    render::Mesh baked = mesh;
    render::bake_occlusion(baked, int(state.range(1)));
    benchmark::DoNotOptimize(baked.occlusion.data());
  }
  state.counters["vertices"] = double(mesh.vertex_count());
  state.counters["threads"] = double(tbb::info::default_concurrency());
}

}  // namespace
BENCHMARK(BM_BakeOcclusion)
    ->ArgNames({"splits", "directions"})
    ->ArgsProduct({{0, 1, 2}, {1024, 2048}})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
