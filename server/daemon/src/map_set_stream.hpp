// One map set for a session's client: computed from a snapshot of the captured map below the
// live path's priority (its own low-priority oneTBB arena, threads at kBackgroundNice, stepping
// aside for frames: frame_path_gate.hpp), then streamed as
// messages — Progress every tenth of the tiles, a coarse preview of each Phong map (level 2, one
// tile), the full-resolution 64x64 tiles, then MapSetComplete (protocol/PROTOCOL.md, item 7);
// to a client that takes changes, only the tiles that changed since a set it holds.
// A GGX chain's set sends each level's tiles, level 0 first (its small levels are its preview).
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <stop_token>
#include <vector>

#include "arlight/common/projection.hpp"
#include "arlight/lighting/ggx.hpp"
#include "arlight/protocol/wire.hpp"
#include "frame_path_gate.hpp"
#include "map_set_delta.hpp"
#include "map_request.hpp"

namespace arlight::daemon {

inline constexpr int kTileSide = 64;  // level-0 tile side sent to clients

struct MapSetJob {
  MapRequest request;
  EnvMap input;              // the captured map when the set was started (reduced: a preview)
  std::uint32_t id = 0;      // the set's number in its session
  double coverage = 0;       // of `input`
  std::uint64_t frames = 0;  // merged into `input`
  // A set while frames still arrive: `input` is the map reduced to preview_input_layout()
  // (issue 16 §3: ~3.7x faster at 128², mean error 0.5 %, up to 23 % beside lights, venice),
  // and the maps are recomputed only where it changed since the last preview (`previews`);
  // the session follows it with a full one once frames pause.
  bool preview = false;
  // A preview's: the session's previews so far (lighting::MapUpdater, made for `request`, used
  // by one set at a time), and the share of each texel of `input` that was measured.
  std::shared_ptr<lighting::MapUpdater> previews = nullptr;
  std::vector<float> measured = {};
  // A GGX chain's preview: the session's preview chains so far (at ggx_preview_spec()).
  std::shared_ptr<lighting::GgxUpdater> ggx_previews = nullptr;
  // The daemon's frames, which the computation steps aside for (none: it never does).
  FramePathGate* frame_path = nullptr;
  // The watchers' GGX chain (Session::watcher_request): sent to them only, never to the client.
  bool for_watchers = false;
  // Read for every tile: a client that reconnects mid-set (perhaps another kind of client,
  // a browser without zstd) gets the rest in the coding it accepts.
  std::function<wire::TileCoding()> tile_coding = [] { return wire::TileCoding::ZstdHalf; };
};

// The input layout of a preview set for maps in `output`: a cube map with about twice the
// output's texels on the sphere (face sqrt(2T/6), a multiple of 8: 64 for a 128² angle map),
// so its texels are about 0.7 of the output's apart, fine enough for every lobe the output
// can show but the narrowest next to a light.
EnvLayout preview_input_layout(const EnvLayout& output);

// A GGX chain's preview while frames arrive (issue 34 §2): at most kGgxPreviewFace a face, with
// as many levels as the request (so each level keeps its roughness), from the map reduced to
// ggx_preview_input(): GgxUpdater then recomputes a chain in ~60-70 ms on two cores.
inline constexpr int kGgxPreviewFace = 128;
lighting::GgxChainSpec ggx_preview_spec(const MapRequest& request);
// The layout a GGX preview's input is reduced to from a capture in `capture`: a cube of the
// largest face up to the preview's that divides the capture's face (a box filter the capture
// makes cheaply on the frame's path: 192 -> 96; another ratio resamples the whole map there).
EnvLayout ggx_preview_input(const MapRequest& request, const EnvLayout& capture);
lighting::GgxChainSpec ggx_spec(const MapRequest& request);

// Who a message of a set is for: a client sent only what changed gets its own MapSetComplete
// and not the tiles it holds, which the watchers (sent whole sets) still get.
enum class Audience { Everyone, Client, Watchers };
using MapSetSink = std::function<void(const wire::Message&, Audience)>;

// Computes and sends the set; returns its seconds when it completed, or a negative number when
// it was stopped. A failure of the computation is sent as Error{Internal}. With `changes`
// (begun for this set against `base`: MapSetDeltas::begin), the client is sent the level-0
// tiles that changed since `base` and a MapSetComplete naming it; without, every tile.
double stream_map_set(const MapSetJob& job, std::stop_token stop, const MapSetSink& send,
                      MapSetDeltas* changes = nullptr, std::uint32_t base = 0);
// Every message to everyone: a whole set.
double stream_map_set(const MapSetJob& job, std::stop_token stop,
                      const std::function<void(const wire::Message&)>& send);

}  // namespace arlight::daemon
