#include "map_set_stream.hpp"

#include <tbb/task_arena.h>
#include <tbb/task_scheduler_observer.h>

#include <algorithm>
#include <optional>
#include <chrono>
#include <cmath>
#include <cstring>
#include <string>

#include "arlight/common/resample.hpp"
#include "arlight/lighting/lighting.hpp"
#include "priority.hpp"

namespace arlight::daemon {

namespace {

// TBB workers drop to the map computation's priority when they join its arena (in arlightd
// TBB only ever runs background work: map sets, and the SH of a resumed session).
class BackgroundPriority : public tbb::task_scheduler_observer {
 public:
  explicit BackgroundPriority(tbb::task_arena& arena) : tbb::task_scheduler_observer(arena) {
    observe(true);
  }
  ~BackgroundPriority() override { observe(false); }
  void on_scheduler_entry(bool) override { lower_thread_priority(); }
};

}  // namespace

EnvLayout preview_input_layout(const EnvLayout& output) {
  const double texels = double(texel_table(output)->size());
  const int face = std::max(8, int(std::lround(std::sqrt(2.0 * texels / 6.0) / 8.0)) * 8);
  return EnvLayout::for_size(Projection::Cube, face);
}

lighting::GgxChainSpec ggx_spec(const MapRequest& request) {
  return {.face = request.size, .min_face = request.ggx_min_face()};
}

lighting::GgxChainSpec ggx_preview_spec(const MapRequest& request) {
  lighting::GgxChainSpec spec = ggx_spec(request);
  while (spec.face > kGgxPreviewFace) {
    spec.face /= 2;
    spec.min_face = std::max(1, spec.min_face / 2);
  }
  return spec;
}

EnvLayout ggx_preview_input(const MapRequest& request, const EnvLayout& capture) {
  const int target = ggx_preview_spec(request).face;
  if (capture.projection() != Projection::Cube)
    return EnvLayout::for_size(Projection::Cube, target);
  const int face = capture.face_size();
  int best = 1;
  for (int d = 1; d <= std::min(face, target); ++d)
    if (face % d == 0) best = d;
  return EnvLayout::for_size(Projection::Cube, best);
}

namespace {

// A set's maps as they go on the wire: each with its shininess (Phong) or roughness (GGX).
struct SetMaps {
  wire::MapKind kind = wire::MapKind::Phong;
  std::vector<EnvMap> maps;
  std::vector<float> shininess, roughness;
  std::vector<SpecularLight> lights;  // Ggx: taken out of the chain's room
};

SetMaps compute_set(const MapSetJob& job, const lighting::Hooks& hooks) {
  const MapRequest& request = job.request;
  SetMaps set;
  set.kind = request.kind;
  if (request.kind == wire::MapKind::Ggx) {
    // With specular_lights the chain is of the room less its small, bright lights (issue 51 §1).
    std::optional<SpecularSplit> split;
    if (request.specular_lights > 0) {
      split = split_specular_lights(job.input, {.max_lights = request.specular_lights});
      set.lights = split->lights;
    }
    const EnvMap& input = split ? split->residual : job.input;
    lighting::GgxChain chain =
        job.ggx_previews ? job.ggx_previews->update(input, hooks, job.measured)
                         : lighting::compute_ggx_chain(input, ggx_spec(request), hooks);
    for (lighting::GgxLevel& l : chain.levels) {
      set.maps.push_back(std::move(l.map));
      set.shininess.push_back(0.0f);
      set.roughness.push_back(float(l.roughness));
    }
    return set;
  }
  const EnvLayout layout = EnvLayout::for_size(request.projection, request.size);
  lighting::ComputedMapSet maps =
      job.previews ? job.previews->update(job.input, hooks, job.measured)
                   : lighting::compute_maps(job.input, request.shininess, layout,
                                            lighting::parse_method(request.method), hooks);
  for (std::size_t k = 0; k < maps.maps.size(); ++k) {
    set.maps.push_back(std::move(maps.maps[k]));
    set.shininess.push_back(float(request.shininess[k]));
    set.roughness.push_back(0.0f);
  }
  return set;
}

}  // namespace

double stream_map_set(const MapSetJob& job, std::stop_token stop,
                      const std::function<void(const wire::Message&)>& send) {
  return stream_map_set(job, stop, [&](const wire::Message& m, Audience) { send(m); });
}

double stream_map_set(const MapSetJob& job, std::stop_token stop, const MapSetSink& send_to,
                      MapSetDeltas* changes, std::uint32_t base) {
  const auto send = [&](const wire::Message& m) { send_to(m, Audience::Everyone); };
  using Clock = std::chrono::steady_clock;
  const auto t0 = Clock::now();
  const std::uint32_t id = job.id;
  lower_thread_priority();
  lighting::Hooks hooks;
  hooks.stop = stop;
  if (job.frame_path) hooks.step_aside = [gate = job.frame_path] { gate->step_aside(); };
  std::size_t last_reported = 0;
  hooks.on_tile = [&](const lighting::TileDone& t) {
    if (t.done * 10 / t.total == last_reported) return;  // every tenth
    last_reported = t.done * 10 / t.total;
    send(wire::Progress{id, std::uint32_t(t.done), std::uint32_t(t.total)});
  };
  try {
    SetMaps set;
    // Below the live path: the frames of every session come first.
    tbb::task_arena arena(tbb::task_arena::automatic, 1, tbb::task_arena::priority::low);
    arena.initialize();
    const BackgroundPriority background(arena);
    arena.execute([&] { set = compute_set(job, hooks); });
    const auto texels_of = [](const Image& img, int x, int y, int w, int h) {
      std::vector<float> px(std::size_t(w) * h * 3);
      for (int r = 0; r < h; ++r)
        std::memcpy(&px[std::size_t(r) * w * 3], img.view().pixel(x, y + r),
                    sizeof(float) * 3 * std::size_t(w));
      return px;
    };
    const auto tile_message = [&](std::size_t map, const std::vector<float>& px, int level, int x,
                                  int y, int w, int h) {
      const wire::TileCoding coding = job.tile_coding();
      const EnvLayout& layout = set.maps[map].layout;
      return wire::MapTile{.map_set = id,
                           .map_index = std::uint16_t(map),
                           .shininess = set.shininess[map],
                           .projection = layout.projection(),
                           .map_width = std::uint32_t(layout.width()),
                           .map_height = std::uint32_t(layout.height()),
                           .level = std::uint8_t(level),
                           .x = std::uint32_t(x),
                           .y = std::uint32_t(y),
                           .width = std::uint32_t(w),
                           .height = std::uint32_t(h),
                           .data = wire::encode_half_rgb(px.data(), px.size() / 3, coding),
                           .coding = coding,
                           .kind = set.kind,
                           .roughness = set.roughness[map]};
    };
    if (changes) {  // maps of another size than the base's: whole
      MapSetDeltas::Shape shape;
      for (const EnvMap& m : set.maps)
        shape.emplace_back(std::uint32_t(m.layout.width()), std::uint32_t(m.layout.height()));
      base = changes->shape(std::move(shape));
    }
    // Phong: coarse first, each map 4x smaller in one tile (a preview the client can use at
    // once), then the full-resolution tiles. A client sent changes holds a whole set already:
    // no coarse preview.
    if (set.kind == wire::MapKind::Phong)
      for (std::size_t k = 0; k < set.maps.size() && !stop.stop_requested(); ++k) {
        Image coarse = downsample2x(downsample2x(set.maps[k].image.view()).view());
        send_to(tile_message(k, texels_of(coarse, 0, 0, coarse.width(), coarse.height()), 2, 0, 0,
                             coarse.width(), coarse.height()),
                base != 0 ? Audience::Watchers : Audience::Everyone);
      }
    std::uint32_t tiles = 0, tiles_changed = 0;
    for (std::size_t k = 0; k < set.maps.size(); ++k) {
      const EnvLayout& layout = set.maps[k].layout;
      for (int y = 0; y < layout.height() && !stop.stop_requested(); y += kTileSide)
        for (int x = 0; x < layout.width(); x += kTileSide) {
          const int w = std::min(kTileSide, layout.width() - x);
          const int h = std::min(kTileSide, layout.height() - y);
          const std::vector<float> px = texels_of(set.maps[k].image, x, y, w, h);
          bool changed = true;
          if (changes) {  // compared as the client decodes it: rounded to half floats
            std::string why;
            auto held = wire::decode_half_rgb(
                wire::encode_half_rgb(px.data(), px.size() / 3, wire::TileCoding::Half),
                px.size() / 3, wire::TileCoding::Half, why);
            // A texel beyond half floats (a sun over 65504) reads back as none: sent, as ever.
            if (held)
              changed = changes->changed(
                  {std::uint16_t(k), std::uint32_t(layout.width()), std::uint32_t(layout.height()),
                   std::uint32_t(x), std::uint32_t(y), std::uint32_t(w), std::uint32_t(h)},
                  std::make_shared<const std::vector<float>>(std::move(*held)));
          }
          ++tiles;
          tiles_changed += changed ? 1 : 0;
          send_to(tile_message(k, px, 0, x, y, w, h),
                  changed ? Audience::Everyone : Audience::Watchers);
        }
    }
    if (stop.stop_requested()) return -1.0;
    const double seconds = std::chrono::duration<double>(Clock::now() - t0).count();
    const wire::MapSetComplete whole{id,         std::uint16_t(set.maps.size()), float(seconds),
                                     float(job.coverage), job.frames, 0, tiles, set.lights};
    if (base != 0) {
      wire::MapSetComplete change = whole;
      change.base_set = base;
      change.tiles = tiles_changed;
      send_to(change, Audience::Client);
      send_to(whole, Audience::Watchers);
    } else {
      send(whole);
    }
    if (changes) changes->complete();
    return seconds;
  } catch (const lighting::Cancelled&) {
  } catch (const std::exception& e) {
    send(wire::Error{wire::ErrorCode::Internal, std::string("map computation: ") + e.what()});
  }
  return -1.0;
}

}  // namespace arlight::daemon
