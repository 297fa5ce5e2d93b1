// The light core (arlight_light.wasm): the part of the client that any page or engine needs to
// take arlight's light — the protocol codec and the lighting state (client/net), nothing of the
// renderer — bound for JavaScript. The three.js provider (client/web/three/) speaks the protocol
// through it: a watcher's Hello (PROTOCOL.md item 1), each message the WebSocket brings, and the
// light in the shapes engines take: SH-9 in WebXR's order, the primary light, the GGX chain's
// levels as half-float RGBA cube faces.
#include <emscripten/bind.h>
#include <emscripten/val.h>

#include <Imath/half.h>

#include <cstdint>
#include <string>
#include <vector>

#include "arlight/common/light_sources.hpp"
#include "arlight/net/lighting_state.hpp"
#include "arlight/protocol/wire.hpp"
#include "js_messages.hpp"

namespace arlight::web {

namespace {

using emscripten::val;

// The primary light is found in the chain's mirror level box-filtered to this face (which keeps
// its power; a light tree over a 256-a-face cube would take ~16 times longer in WebAssembly).
constexpr int kPrimaryLightFace = 64;

}  // namespace

class LightClient {
 public:
  // A watcher's Hello for `session`; tiles as raw half floats (a browser has no zstd).
  val hello(const std::string& device, const std::string& token, const std::string& session) {
    wire::Hello h;
    h.client_name = "arlight-three 0.1";
    h.device_id = device;
    h.auth_token = token;
    h.capabilities = {"maps", wire::kCapabilityTilesPlanar, wire::kCapabilityTilesHalf};
    h.watch_session = session;
    state_.expect_any_maps();
    return bytes_to_js(wire::encode(h));
  }
  val ping(double nonce) { return bytes_to_js(wire::encode(wire::Ping{std::uint64_t(nonce)})); }

  // One message from the server: "welcome", "update", "maps" (a GGX chain completed), "error",
  // or "" (nothing the light changed: a tile, progress, a Phong set).
  std::string receive(const val& bytes) {
    std::optional<wire::Message> m = message_from_js(bytes, error_);
    if (!m) return "error";
    switch (state_.receive(std::move(*m))) {
      case client::LightingState::Change::Welcome:
        return "welcome";
      case client::LightingState::Change::Error:
        error_ = state_.error()->first + ": " + state_.error()->second;
        return "error";
      case client::LightingState::Change::Update:
        return "update";
      case client::LightingState::Change::MapSet:
        if (state_.newest_set()->kind != wire::MapKind::Ggx) return "";
        find_primary_light();
        return "maps";
      default:
        return "";
    }
  }

  std::string session_id() const {
    return state_.welcome() ? state_.welcome()->session_id : std::string();
  }
  std::string error() const { return error_; }
  // A Moved error's HOST:PORT: the web port of the arlightd that has the session (issue 49 §2).
  std::string moved_to() const { return state_.moved_to(); }
  double updates() const { return double(state_.updates()); }
  double map_sets() const { return double(state_.map_sets()); }
  double frame_sequence() const { return double(state_.lighting().frame_sequence); }
  double coverage() const { return state_.lighting().coverage; }

  // SH-9 as WebXR and three.js's LightProbe take it (sh.hpp's sh9_webxr); empty before an
  // update.
  val sh9() const {
    const auto& sh = state_.lighting().sh;
    std::vector<float> out;
    if (sh && sh->order >= 3) {
      const std::array<float, 27> webxr = sh9_webxr(*sh);
      out.assign(webxr.begin(), webxr.end());
    }
    return typed_array("Float32Array", out);
  }

  // The primary light (WebXR's primaryLightDirection / primaryLightIntensity): light.json's
  // (primary_light() of the chain) once a chain arrived, before it the newest update's dominant
  // light (from SH bands 0-1).
  val primary() const {
    const client::Lighting& l = state_.lighting();
    const glm::vec3 d = chain_primary_ ? chain_primary_->direction : l.dominant_direction;
    const glm::vec3 c = chain_primary_ ? chain_primary_->colour : l.dominant_colour;
    val out = val::object();
    out.set("direction", typed_array("Float32Array", std::vector<float>{float(d.x), float(d.y), float(d.z)}));
    out.set("intensity", typed_array("Float32Array", std::vector<float>{float(c.x), float(c.y), float(c.z)}));
    return out;
  }

  // The newest complete GGX chain: its levels, each level's face and roughness, and its faces as
  // half-float RGBA (alpha 1), +X, -X, +Y, -Y, +Z, -Z one after another, rows top to bottom as
  // common/CONVENTIONS.md orients them.
  int chain_levels() const { return chain() ? int(chain()->maps.size()) : 0; }
  double chain_version() const { return double(state_.lighting().ggx_version); }
  int chain_face(int level) const { return valid(level) ? chain()->maps[level].layout.width() : 0; }
  double chain_roughness(int level) const { return valid(level) ? chain()->roughness[level] : 0.0; }
  val chain_level_half_rgba(int level) const {
    std::vector<std::uint16_t> out;
    if (valid(level)) {
      const auto v = chain()->maps[std::size_t(level)].image.view();
      out.reserve(std::size_t(v.width) * v.height * 4);
      for (int y = 0; y < v.height; ++y)
        for (int x = 0; x < v.width; ++x) {
          const float* p = v.pixel(x, y);
          for (int c = 0; c < 3; ++c) out.push_back(Imath::half(p[c]).bits());
          out.push_back(Imath::half(1.0f).bits());
        }
    }
    return typed_array("Uint16Array", out);
  }

 private:
  const client::ReceivedMapSet* chain() const { return state_.lighting().ggx.get(); }
  bool valid(int level) const { return chain() && level >= 0 && level < int(chain()->maps.size()); }
  void find_primary_light() {
    const client::ReceivedMapSet* c = chain();
    const auto& sh = state_.lighting().sh;
    if (!c || c->maps.empty() || !sh) return;
    Image mirror = c->maps[0].image;  // level 0: the map itself (roughness 0)
    while (mirror.width() > kPrimaryLightFace && mirror.width() % 2 == 0)
      mirror = downsample2x(mirror.view());
    EnvMap map(EnvLayout(Projection::Cube, mirror.width(), mirror.height()));
    map.image = std::move(mirror);
    chain_primary_ = arlight::primary_light(map, *sh);
  }

  client::LightingState state_;
  std::string error_;
  std::optional<DominantLight> chain_primary_;
};

EMSCRIPTEN_BINDINGS(arlight_light) {
  emscripten::class_<LightClient>("LightClient")
      .constructor<>()
      .function("hello", &LightClient::hello)
      .function("ping", &LightClient::ping)
      .function("receive", &LightClient::receive)
      .function("sessionId", &LightClient::session_id)
      .function("error", &LightClient::error)
      .function("movedTo", &LightClient::moved_to)
      .function("updates", &LightClient::updates)
      .function("mapSets", &LightClient::map_sets)
      .function("frameSequence", &LightClient::frame_sequence)
      .function("coverage", &LightClient::coverage)
      .function("sh9", &LightClient::sh9)
      .function("primaryLight", &LightClient::primary)
      .function("chainLevels", &LightClient::chain_levels)
      .function("chainVersion", &LightClient::chain_version)
      .function("chainFace", &LightClient::chain_face)
      .function("chainRoughness", &LightClient::chain_roughness)
      .function("chainLevelHalfRgba", &LightClient::chain_level_half_rgba);
}

}  // namespace arlight::web
