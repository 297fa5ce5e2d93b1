// The map sets arlightd streams (issue 16 §3): a preview while frames arrive is computed from
// the map reduced to about twice the output's texels, close to the full set and cheaper, and
// recomputes only what changed since the session's last preview.
#include <gtest/gtest.h>
#include <sched.h>
#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <chrono>
#include <mutex>
#include <set>
#include <thread>
#include <utility>

#include "arlight/common/hdr_io.hpp"
#include "arlight/common/resample.hpp"
#include "arlight/common/specular_lights.hpp"
#include "arlight/lighting/lighting.hpp"
#include "map_set_stream.hpp"
#include "priority.hpp"

using namespace arlight;
using namespace arlight::daemon;

TEST(MapSetStream, APreviewsInputHasAboutTwiceTheOutputsTexels) {
  for (const EnvLayout out : {EnvLayout::for_size(Projection::AngleMap, 128),
                              EnvLayout::for_size(Projection::AngleMap, 512),
                              EnvLayout::for_size(Projection::LatLong, 64),
                              EnvLayout::for_size(Projection::Cube, 32)}) {
    const EnvLayout in = preview_input_layout(out);
    EXPECT_EQ(in.projection(), Projection::Cube);
    EXPECT_EQ(in.face_size() % 8, 0);
    const double ratio = double(in.texel_count()) / double(texel_table(out)->size());
    EXPECT_GT(ratio, 1.5) << out.width();
    EXPECT_LT(ratio, 2.7) << out.width();
  }
  EXPECT_EQ(preview_input_layout(EnvLayout::for_size(Projection::AngleMap, 128)).face_size(), 64);
}

namespace {

// The maps a streamed set carries, from its full-resolution tiles (Half coding).
std::vector<EnvMap> stream(const EnvMap& input, const MapRequest& request,
                           std::shared_ptr<lighting::MapUpdater> previews, double& seconds) {
  const EnvLayout layout = EnvLayout::for_size(request.projection, request.size);
  std::vector<EnvMap> maps(request.shininess.size(), EnvMap(layout));
  MapSetJob job{.request = request,
                .input = input,
                .id = 1,
                .preview = previews != nullptr,
                .previews = previews,
                .tile_coding = [] { return wire::TileCoding::Half; }};
  seconds = stream_map_set(job, {}, [&](const wire::Message& m) {
    const auto* t = std::get_if<wire::MapTile>(&m);
    if (!t || t->level != 0) return;
    std::string why;
    const auto px =
        wire::decode_half_rgb(t->data, std::size_t(t->width) * t->height, t->coding, why);
    ASSERT_TRUE(px) << why;
    for (std::uint32_t y = 0; y < t->height; ++y)
      for (std::uint32_t x = 0; x < t->width; ++x)
        for (int c = 0; c < 3; ++c)
          maps[t->map_index]
              .image.data()[3 * ((t->y + y) * std::size_t(layout.width()) + t->x + x) + c] =
              (*px)[3 * (std::size_t(y) * t->width + x) + std::size_t(c)];
  });
  return maps;
}

}  // namespace

TEST(MapSetStream, APreviewSetIsCloseToTheFullOne) {
  const EnvMap venice = resample(
      load_envmap(std::string(ARLIGHT_SOURCE_DIR) + "/data/probes/venice.exr").env,
      EnvLayout::for_size(Projection::Cube, 192));  // arlightd's capture layout
  const MapRequest request{.shininess = {1, 80}, .size = 64};
  const EnvLayout layout = EnvLayout::for_size(request.projection, request.size);
  const EnvMap reduced = reduce(venice, preview_input_layout(layout));
  auto previews = std::make_shared<lighting::MapUpdater>(request.shininess, layout);
  double full_s = 0, preview_s = 0, again_s = 0;
  const auto full = stream(venice, request, nullptr, full_s);
  const auto preview = stream(reduced, request, previews, preview_s);
  ASSERT_GT(full_s, 0.0);
  ASSERT_GT(preview_s, 0.0);
  for (std::size_t k = 0; k < full.size(); ++k) {
    const lighting::MapError e = lighting::map_error(full[k], preview[k]);
    std::printf("s = %g: preview against full: mean %.3f %%, max %.2f %%\n",
                request.shininess[k], 100 * e.mean, 100 * e.max);
    EXPECT_LT(e.mean, 0.01) << request.shininess[k];
    EXPECT_GT(e.mean, 0.0) << "the preview is the full set: was the input reduced?";
  }
  // The next preview of an unchanged map recomputes nothing and sends the same maps.
  const auto again = stream(reduced, request, previews, again_s);
  for (std::size_t k = 0; k < full.size(); ++k) {
    EXPECT_EQ(lighting::map_error(preview[k], again[k]).max, 0.0);
    EXPECT_EQ(previews->recomputed()[k], 0.0);
  }
}

namespace {
int thread_nice() { return ::getpriority(PRIO_PROCESS, static_cast<id_t>(::syscall(SYS_gettid))); }
}  // namespace

// Background work is niced, not idle (issue 37 §2): every thread that computes or sends a map
// set (the set's own, and the TBB workers whose progress it sends) and a checkpoint's run at
// SCHED_OTHER, nice kBackgroundNice, which still gets a share of a busy machine (SCHED_IDLE
// got none). The thread that asked is left as it was.
TEST(MapSetStream, BackgroundThreadsAreNicedNotIdle) {
  static_assert(kBackgroundNice > 0 && kBackgroundNice < 19);
  const EnvMap room(EnvLayout::for_size(Projection::Cube, 16));
  const MapRequest request{.shininess = {1, 8, 64}, .size = 64};
  MapSetJob job{.request = request, .input = room, .id = 1, .tile_coding = [] {
                  return wire::TileCoding::Half;
                }};
  std::mutex mutex;
  std::set<std::pair<int, int>> policy_and_nice;  // of every thread that sent a message
  int sent = 0;
  double seconds = -1.0;
  int asker_nice_before = -100, asker_nice = -100;
  std::thread([&] {
    ASSERT_EQ(::sched_getscheduler(0), SCHED_OTHER);
    asker_nice_before = thread_nice();
    std::thread([&] {  // arlightd's map thread: lowers itself for good
      seconds = stream_map_set(job, {}, [&](const wire::Message&) {
        std::lock_guard lock(mutex);
        ++sent;
        policy_and_nice.insert({::sched_getscheduler(0), thread_nice()});
      });
    }).join();
    asker_nice = thread_nice();
  }).join();
  EXPECT_GT(seconds, 0.0);
  EXPECT_GT(sent, 3);
  EXPECT_EQ(policy_and_nice, (std::set<std::pair<int, int>>{{SCHED_OTHER, kBackgroundNice}}));
  EXPECT_EQ(asker_nice, asker_nice_before);

  int policy = -1, nice = -100;
  std::thread([&] {
    lower_thread_priority();
    policy = ::sched_getscheduler(0);
    nice = thread_nice();
  }).join();
  EXPECT_EQ(policy, SCHED_OTHER);
  EXPECT_EQ(nice, kBackgroundNice);
}

// Issue 34 §2: a GGX chain's set. Its preview keeps the request's levels (so each level keeps its
// roughness) at a face <= 128, from the capture reduced by a whole factor; its tiles carry the
// kind and the roughness, and put back together they are the chain, in half precision.
TEST(MapSetStream, AGgxChainsPreviewAndTilesSayWhatTheyAre) {
  const MapRequest request{.shininess = {}, .size = 256, .kind = wire::MapKind::Ggx};
  const lighting::GgxChainSpec preview = ggx_preview_spec(request);
  EXPECT_EQ(preview.face, 128);
  EXPECT_EQ(preview.min_face, 8);  // 5 levels, as 256 -> 16
  EXPECT_EQ(ggx_preview_spec(MapRequest{.shininess = {}, .size = 64, .kind = wire::MapKind::Ggx}).face, 64);
  EXPECT_EQ(ggx_preview_input(request, EnvLayout::for_size(Projection::Cube, 192)).face_size(), 96);
  EXPECT_EQ(ggx_preview_input(request, EnvLayout::for_size(Projection::Cube, 256)).face_size(), 128);

  const EnvMap venice = resample(
      load_envmap(std::string(ARLIGHT_SOURCE_DIR) + "/data/probes/venice.exr").env,
      EnvLayout::for_size(Projection::Cube, 32));
  const MapRequest small{.shininess = {}, .size = 32, .kind = wire::MapKind::Ggx, .levels = 3};
  const lighting::GgxChain chain = lighting::compute_ggx_chain(venice, ggx_spec(small));
  std::vector<EnvMap> got;
  for (const auto& l : chain.levels) got.emplace_back(l.map.layout);
  std::size_t tiles = 0, complete_maps = 0;
  MapSetJob job{.request = small, .input = venice, .id = 4, .tile_coding = [] {
                  return wire::TileCoding::Half;
                }};
  const double seconds = stream_map_set(job, {}, [&](const wire::Message& m) {
    if (const auto* done = std::get_if<wire::MapSetComplete>(&m)) complete_maps = done->maps;
    const auto* t = std::get_if<wire::MapTile>(&m);
    if (!t) return;
    ++tiles;
    ASSERT_EQ(t->kind, wire::MapKind::Ggx);
    ASSERT_LT(t->map_index, 3);
    EXPECT_EQ(t->level, 0) << "a chain has no coarse preview tiles";
    EXPECT_FLOAT_EQ(t->roughness, float(chain.levels[t->map_index].roughness));
    EXPECT_EQ(t->projection, Projection::Cube);
    EnvMap& map = got[t->map_index];
    ASSERT_EQ(t->map_width, std::uint32_t(map.layout.width()));
    ASSERT_EQ(t->map_height, std::uint32_t(map.layout.height()));
    std::string why;
    const auto px = wire::decode_half_rgb(t->data, std::size_t(t->width) * t->height, t->coding, why);
    ASSERT_TRUE(px) << why;
    for (std::uint32_t y = 0; y < t->height; ++y)
      for (std::uint32_t x = 0; x < t->width; ++x)
        for (int c = 0; c < 3; ++c)
          map.image.data()[3 * ((t->y + y) * std::size_t(map.layout.width()) + t->x + x) + c] =
              (*px)[3 * (std::size_t(y) * t->width + x) + std::size_t(c)];
  });
  ASSERT_GT(seconds, 0.0);
  EXPECT_EQ(complete_maps, 3u);
  EXPECT_EQ(tiles, 3u + 2u + 1u);  // 32x192, 16x96, 8x48 in 64x64 tiles
  for (std::size_t k = 0; k < 3; ++k)
    EXPECT_LT(lighting::map_error(chain.levels[k].map, got[k]).max, 1e-3) << "level " << k;
}

// A chain asked for with specular_lights (issue 51 §1): the tiles are the chain of the room
// less its small, bright lights, and MapSetComplete carries those lights.
TEST(MapSetStream, AGgxChainWithLightsSendsTheResidualAndTheLights) {
  const EnvMap park = resample(load_envmap(std::string(ARLIGHT_SOURCE_DIR) + "/data/probes/park.exr").env,
                               EnvLayout::for_size(Projection::Cube, 32));
  const MapRequest request{.shininess = {}, .size = 32, .kind = wire::MapKind::Ggx, .levels = 3,
                           .specular_lights = 4};
  const SpecularSplit split = split_specular_lights(park, {.max_lights = 4});
  ASSERT_EQ(split.lights.size(), 1u);  // the sun
  const lighting::GgxChain residual = lighting::compute_ggx_chain(split.residual, ggx_spec(request));
  const lighting::GgxChain whole = lighting::compute_ggx_chain(park, ggx_spec(request));
  std::vector<SpecularLight> lights;
  double worst_residual = 0, worst_whole = 0;
  MapSetJob job{.request = request, .input = park, .id = 2, .tile_coding = [] {
                  return wire::TileCoding::Half;
                }};
  stream_map_set(job, {}, [&](const wire::Message& m) {
    if (const auto* done = std::get_if<wire::MapSetComplete>(&m)) lights = done->lights;
    const auto* t = std::get_if<wire::MapTile>(&m);
    if (!t || t->map_index != 1) return;
    std::string why;
    const auto px = wire::decode_half_rgb(t->data, std::size_t(t->width) * t->height, t->coding, why);
    ASSERT_TRUE(px) << why;
    const EnvMap& r = residual.levels[1].map;
    const EnvMap& w = whole.levels[1].map;
    for (std::uint32_t y = 0; y < t->height; ++y)
      for (std::uint32_t x = 0; x < t->width; ++x)
        for (int c = 0; c < 3; ++c) {
          const std::size_t at = 3 * ((t->y + y) * std::size_t(r.layout.width()) + t->x + x) + std::size_t(c);
          const double got = (*px)[3 * (std::size_t(y) * t->width + x) + std::size_t(c)];
          worst_residual = std::max(worst_residual, std::abs(got - r.image.data()[at]) / (r.image.data()[at] + 1e-3));
          worst_whole = std::max(worst_whole, std::abs(got - w.image.data()[at]) / (w.image.data()[at] + 1e-3));
        }
  });
  EXPECT_EQ(lights, split.lights);
  EXPECT_LT(worst_residual, 2e-3);  // half floats
  EXPECT_GT(worst_whole, 0.1);      // the sun is not in it
}
