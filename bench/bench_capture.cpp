// Capture: one 640x480 JPEG frame into a 512x512 angle map on one core — decode, linearise,
// project, live SH update (order 8) — the issue's <= 8 ms median budget; and the same with the
// feature alignment. Frames are views of venice rendered here (sRGB, q90 JPEG) while the camera
// turns, so each frame overlaps the map captured so far as in a real sweep. `fill_ms` is what
// the fill of the unseen part adds per frame (the daemon's LightingUpdate asks for the filled
// SH after every frame), measured beside --fill none, and beside a refit of the fill's model
// after every frame (`refit_every_frame`; the default refits after 8 frames or 2 % of new
// coverage and follows the frames in between). `fill_mean_ms` counts the refits' share.
#include <benchmark/benchmark.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <glm/gtc/quaternion.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "arlight/capture/capture.hpp"
#include "arlight/common/hdr_io.hpp"
#include "arlight/common/resample.hpp"
#include "arlight/lighting/lighting.hpp"
#include "arlight/sim/view.hpp"

using namespace arlight;

namespace {

constexpr int kFrames = 64;  // a turn of 360 degrees in 64 views at pitch 0 and 20 degrees

glm::dquat view(int k) {
  return glm::angleAxis(glm::radians(360.0 * k / 32), glm::dvec3(0, 1, 0)) *
         glm::angleAxis(glm::radians(k < 32 ? 0.0 : 20.0), glm::dvec3(1, 0, 0));
}

// A q90 JPEG of what a 60-degree 640x480 sRGB camera at exposure `exposure` sees of venice
// towards `q`.
std::vector<std::uint8_t> venice_view(const glm::dquat& q, double exposure) {
  static const EnvMap env =
      load_envmap(std::string(ARLIGHT_SOURCE_DIR) + "/data/probes/venice.exr").env;
  static const EnvSampler sampler(env);
  const cv::Mat im =
      sim::ideal_view(sampler, CameraIntrinsics::from_fov(640, 480, 60), q, exposure);
  std::vector<std::uint8_t> jpeg;
  cv::imencode(".jpg", im, jpeg, {cv::IMWRITE_JPEG_QUALITY, 90});
  return jpeg;
}

// The turn's views at exposure `exposure`, rendered once.
const std::vector<std::vector<std::uint8_t>>& frames(double exposure) {
  static std::vector<std::vector<std::uint8_t>> jpegs;
  if (jpegs.empty())
    for (int f = 0; f < kFrames; ++f) jpegs.push_back(venice_view(view(f), exposure));
  return jpegs;
}

void BM_CaptureFrame(benchmark::State& state, bool align, capture::Fill fill,
                     int fill_refit_frames = capture::CaptureOptions{}.fill_refit_frames) {
  tbb::global_control one_core(tbb::global_control::max_allowed_parallelism, 1);
  const double exposure = 0.3;  // venice's mean radiance ~0.6 -> mid-grey
  const auto& jpegs = frames(exposure);
  capture::CaptureOptions options;  // 512x512 angle map, SH order 8
  options.align = align;
  options.fill = fill;
  options.fill_refit_frames = fill_refit_frames;
  capture::CaptureSession session(CameraIntrinsics::from_fov(640, 480, 60), CameraResponse::srgb(),
                                  options);
  std::vector<double> ms, decode, linearize, align_ms, project, sh, fill_ms;
  std::size_t aligned = 0, k = 0;
  for (auto _ : state) {
    const int f = int(k++ % kFrames);
    const capture::FrameResult r = session.add_encoded(jpegs[f], {0.0, exposure, 1.0, view(f)});
    if (!r.used) state.SkipWithError(r.skipped_reason.c_str());
    const auto t0 = std::chrono::steady_clock::now();
    benchmark::DoNotOptimize(session.sh().c[0]);
    fill_ms.push_back(
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
    ms.push_back(r.total_ms() + fill_ms.back());
    decode.push_back(r.decode_ms), linearize.push_back(r.linearize_ms);
    align_ms.push_back(r.align_ms), project.push_back(r.project_ms), sh.push_back(r.sh_ms);
    aligned += r.aligned;
  }
  const auto median = [](std::vector<double> v) {
    std::sort(v.begin(), v.end());
    return v[v.size() / 2];
  };
  state.counters["median_ms"] = median(ms);
  state.counters["decode_ms"] = median(decode);
  state.counters["linearize_ms"] = median(linearize);
  state.counters["align_ms"] = median(align_ms);
  state.counters["project_ms"] = median(project);
  state.counters["sh_ms"] = median(sh);
  state.counters["fill_ms"] = median(fill_ms);
  double fill_sum = 0.0;
  for (double v : fill_ms) fill_sum += v;
  state.counters["fill_mean_ms"] = fill_sum / double(fill_ms.size());
  state.counters["aligned_pct"] = 100.0 * double(aligned) / double(ms.size());
  state.counters["coverage_pct"] = 100.0 * session.coverage();
}

// Issue 16 §3: arlightd's previews while a phone sweeps venice (the turn above, arlightd's
// capture: a face-192 cube map for 512, the fill). Every third frame (~10 Hz at 30 fps) the
// map reduced to the preview's face-64 cube (CaptureSession::reduced_environment) gets its 8
// maps at 128^2, twice: from scratch (compute_maps, before) and by the session's MapUpdater
// (recomputing what changed), on every core. Counters: the median ms of each, the median share of
// input texels changed and of the narrowest map's output recomputed, and the updater's worst mean /
// max error against the fresh maps over the sweep.
void BM_PreviewSweep(benchmark::State& state) {
  const auto& jpegs = frames(0.3);
  capture::CaptureOptions options;
  options.layout = capture::capture_layout_for(512);
  capture::CaptureSession session(CameraIntrinsics::from_fov(640, 480, 60), CameraResponse::srgb(),
                                  options);
  const std::vector<double> shininess = {1, 10, 20, 40, 80, 160, 320, 1280};
  const EnvLayout out = EnvLayout::for_size(Projection::AngleMap, 128);
  const EnvLayout reduced = EnvLayout::for_size(Projection::Cube, 64);
  lighting::MapUpdater updater(shininess, out);
  std::vector<double> full_ms, update_ms, changed, narrowest;
  double worst_mean = 0.0, worst_max = 0.0;
  std::size_t k = 0;
  for (auto _ : state) {
    for (int f = 0; f < 3; ++f, ++k)
      session.add_encoded(jpegs[k % kFrames], {0.0, 0.3, 1.0, view(int(k % kFrames))});
    const auto [input, measured] = session.reduced_environment(reduced);
    auto t0 = std::chrono::steady_clock::now();
    const lighting::ComputedMapSet fresh = lighting::compute_maps(input, shininess, out, {});
    full_ms.push_back(
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
    t0 = std::chrono::steady_clock::now();
    const lighting::ComputedMapSet& maps = updater.update(input, {}, measured);
    update_ms.push_back(
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
    changed.push_back(updater.changed());
    narrowest.push_back(updater.recomputed().back());
    for (std::size_t m = 0; m < shininess.size(); ++m) {
      const lighting::MapError e = lighting::map_error(fresh.maps[m], maps.maps[m]);
      worst_mean = std::max(worst_mean, e.mean), worst_max = std::max(worst_max, e.max);
    }
  }
  const auto median = [](std::vector<double> v) {
    std::sort(v.begin(), v.end());
    return v[v.size() / 2];
  };
  state.counters["full_ms"] = median(full_ms);
  state.counters["update_ms"] = median(update_ms);
  state.counters["changed_pct"] = 100.0 * median(changed);
  state.counters["s1280_recomputed_pct"] = 100.0 * median(narrowest);
  state.counters["worst_mean_pct"] = 100.0 * worst_mean;
  state.counters["worst_max_pct"] = 100.0 * worst_max;
}
BENCHMARK(BM_PreviewSweep)->Iterations(42)->Unit(benchmark::kMillisecond)->UseRealTime();

// What a session costs arlightd when it starts (on a network thread, at its CameraIntrinsics):
// a capture session at arlightd's layout and fill, and its first frame, on one core. The
// layout's tables are made by the first session of the process (before the timing here).
void BM_CaptureSessionStart(benchmark::State& state) {
  tbb::global_control one_core(tbb::global_control::max_allowed_parallelism, 1);
  const auto& jpegs = frames(0.3);
  capture::CaptureOptions options;
  options.layout = capture::capture_layout_for(512);
  options.align_async = true;
  const CameraIntrinsics camera = CameraIntrinsics::from_fov(640, 480, 60);
  capture::CaptureSession(camera, CameraResponse::srgb(), options);  // the layout's tables
  std::vector<double> open_ms, first_ms;
  for (auto _ : state) {
    const auto t0 = std::chrono::steady_clock::now();
    capture::CaptureSession session(camera, CameraResponse::srgb(), options);
    const auto t1 = std::chrono::steady_clock::now();
    session.add_encoded(jpegs[0], {0.0, 0.3, 1.0, view(0)});
    benchmark::DoNotOptimize(session.sh());
    const auto t2 = std::chrono::steady_clock::now();
    open_ms.push_back(std::chrono::duration<double, std::milli>(t1 - t0).count());
    first_ms.push_back(std::chrono::duration<double, std::milli>(t2 - t1).count());
  }
  std::sort(open_ms.begin(), open_ms.end());
  std::sort(first_ms.begin(), first_ms.end());
  state.counters["open_ms"] = open_ms[open_ms.size() / 2];
  state.counters["first_frame_ms"] = first_ms[first_ms.size() / 2];
}
BENCHMARK(BM_CaptureSessionStart)->Iterations(20)->Unit(benchmark::kMillisecond)->UseRealTime();

// Issue 16 §2: the cost of a frame by where the camera looks, in a capture layout. Eight
// directions of a sweep (ahead, right, behind, left at the horizon; up; down; behind 45 degrees
// up and down): the median ms of each, and max / min over the eight (the target is <= 1.5). In
// an angle map the texels near the back pole cover up to ~17x less solid angle than ahead, so
// a frame looking behind projects many more of them.
void BM_CaptureByDirection(benchmark::State& state, Projection projection, int size, bool align) {
  tbb::global_control one_core(tbb::global_control::max_allowed_parallelism, 1);
  static const std::vector<std::pair<const char*, glm::dquat>> directions = [] {
    const auto yp = [](double yaw, double pitch) {
      return glm::angleAxis(glm::radians(yaw), glm::dvec3(0, 1, 0)) *
             glm::angleAxis(glm::radians(pitch), glm::dvec3(1, 0, 0));
    };
    return std::vector<std::pair<const char*, glm::dquat>>{
        {"ahead", yp(0, 0)},        {"right", yp(-90, 0)},
        {"behind", yp(180, 0)},     {"left", yp(90, 0)},
        {"up", yp(0, 85)},          {"down", yp(0, -85)},
        {"behind_up", yp(180, 45)}, {"behind_down", yp(180, -45)}};
  }();
  // One JPEG of venice a direction (exposure 0.3), rendered once.
  static std::vector<std::vector<std::uint8_t>> jpegs;
  if (jpegs.empty())
    for (const auto& [name, q] : directions) jpegs.push_back(venice_view(q, 0.3));
  capture::CaptureOptions options;
  options.layout = EnvLayout::for_size(projection, size);
  options.align = align;  // every frame (8 directions in turn), at 160 px as arlightd
  options.align_max_width = 160;
  options.fill = capture::Fill::None;
  capture::CaptureSession session(CameraIntrinsics::from_fov(640, 480, 60), CameraResponse::srgb(),
                                  options);
  std::vector<std::vector<double>> ms(directions.size());
  std::size_t k = 0;
  for (auto _ : state) {
    const std::size_t d = k++ % directions.size();
    const capture::FrameResult r =
        session.add_encoded(jpegs[d], {0.0, 0.3, 1.0, directions[d].second});
    if (!r.used) state.SkipWithError(r.skipped_reason.c_str());
    ms[d].push_back(r.total_ms());
  }
  double lo = 1e30, hi = 0.0;
  for (std::size_t d = 0; d < directions.size(); ++d) {
    std::sort(ms[d].begin(), ms[d].end());
    const double median = ms[d][ms[d].size() / 2];
    state.counters[std::string(directions[d].first) + "_ms"] = median;
    lo = std::min(lo, median), hi = std::max(hi, median);
  }
  state.counters["max_over_min"] = hi / lo;
  state.counters["texels"] = double(texel_table(options.layout)->size());
}

}  // namespace

BENCHMARK_CAPTURE(BM_CaptureByDirection, anglemap_512, Projection::AngleMap, 512, false)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(8 * 32);
BENCHMARK_CAPTURE(BM_CaptureByDirection, cube_192, Projection::Cube, 192, false)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(8 * 32);
BENCHMARK_CAPTURE(BM_CaptureByDirection, latlong_256, Projection::LatLong, 256, false)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(8 * 32);
BENCHMARK_CAPTURE(BM_CaptureByDirection, anglemap_512_aligned, Projection::AngleMap, 512, true)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(8 * 32);
BENCHMARK_CAPTURE(BM_CaptureByDirection, cube_192_aligned, Projection::Cube, 192, true)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(8 * 32);
// Issue 37 §1: frames that add nothing, as arlightd gets them from a phone that follows the
// frame advice (320x240 of a 640x480 camera, re-encoded q90) once the turn above is captured
// (three turns, the last two agreeing): each frame of a fourth turn, with the glance
// (CaptureOptions::glance) or without, in one process, on one core. Counters: the median
// ms a frame (and of the glanced frames) and the shares of the frames the glance / the full
// test found unchanged.
void BM_SettledFrame(benchmark::State& state, bool glance) {
  tbb::global_control one_core(tbb::global_control::max_allowed_parallelism, 1);
  static const std::vector<std::vector<std::uint8_t>> reduced = [] {
    std::vector<std::vector<std::uint8_t>> out;
    for (const auto& jpeg : frames(0.3)) {
      const cv::Mat full = cv::imdecode(jpeg, cv::IMREAD_COLOR);
      cv::Mat half;
      cv::resize(full, half, cv::Size(320, 240), 0, 0, cv::INTER_AREA);
      out.emplace_back();
      cv::imencode(".jpg", half, out.back(), {cv::IMWRITE_JPEG_QUALITY, 90});
    }
    return out;
  }();
  capture::CaptureOptions options;
  options.layout = capture::capture_layout_for(512);
  options.align_async = true, options.align_every = 4;  // as arlightd
  options.glance = glance;
  capture::CaptureSession session(CameraIntrinsics::from_fov(640, 480, 60), CameraResponse::srgb(),
                                  options);
  double t = 0.0;
  for (int k = 0; k < 3 * kFrames; ++k, t += 1.0 / 30)
    session.add_encoded(reduced[std::size_t(k % kFrames)], {t, 0.3, 1.0, view(k % kFrames)});
  std::vector<double> ms, glanced_ms;
  std::size_t glanced = 0, unchanged = 0, k = 0;
  for (auto _ : state) {
    const int f = int(k++ % kFrames);
    const auto t0 = std::chrono::steady_clock::now();
    const capture::FrameResult r =
        session.add_encoded(reduced[std::size_t(f)], {t, 0.3, 1.0, view(f)});
    benchmark::DoNotOptimize(session.sh().c[0]);
    ms.push_back(
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
    t += 1.0 / 30;
    if (!r.used) state.SkipWithError(r.skipped_reason.c_str());
    glanced += r.glanced, unchanged += r.unchanged;
    if (r.glanced) glanced_ms.push_back(ms.back());
  }
  std::sort(ms.begin(), ms.end());
  std::sort(glanced_ms.begin(), glanced_ms.end());
  state.counters["median_ms"] = ms[ms.size() / 2];
  state.counters["glanced_median_ms"] =
      glanced_ms.empty() ? 0.0 : glanced_ms[glanced_ms.size() / 2];
  state.counters["glanced_pct"] = 100.0 * double(glanced) / double(ms.size());
  state.counters["unchanged_pct"] = 100.0 * double(unchanged) / double(ms.size());
}

BENCHMARK_CAPTURE(BM_SettledFrame, glance, true)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(kFrames)
    ->UseRealTime();
BENCHMARK_CAPTURE(BM_SettledFrame, no_glance, false)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(kFrames)
    ->UseRealTime();
BENCHMARK_CAPTURE(BM_CaptureFrame, no_align, false, capture::Fill::Estimate)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(256);
BENCHMARK_CAPTURE(BM_CaptureFrame, no_align_refit_every_frame, false, capture::Fill::Estimate, 1)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(256);
BENCHMARK_CAPTURE(BM_CaptureFrame, no_align_fill_none, false, capture::Fill::None)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(256);
BENCHMARK_CAPTURE(BM_CaptureFrame, aligned, true, capture::Fill::Estimate)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(256);
