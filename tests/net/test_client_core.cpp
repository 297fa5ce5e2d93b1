// The client core (client/net): map sets as their tiles arrive (MapSetAssembler: only whole sets
// are used), and the lighting state the server's messages build (LightingState, which both
// clients' receive paths call).
#include <gtest/gtest.h>

#include <map>
#include <utility>
#include <vector>

#include "arlight/net/client_messages.hpp"
#include "arlight/net/frame_pacer.hpp"
#include "arlight/net/lighting_state.hpp"
#include "arlight/net/map_assembly.hpp"
#include "arlight/net/unsaved_frames.hpp"

using namespace arlight;
using namespace arlight::client;

namespace {

// Angle maps of 16x16 in 8x8 tiles; each map's texels hold its index + 1.
constexpr int kSize = 16, kTile = 8;

// One 8x8 tile of map k of `set`, every texel `value`.
wire::MapTile tile_of(std::uint32_t set, int k, int x, int y, float value) {
  const std::vector<float> px(std::size_t(kTile * kTile * 3), value);
  return {.map_set = set,
          .map_index = std::uint16_t(k),
          .shininess = float(10 * (k + 1)),
          .projection = Projection::AngleMap,
          .map_width = kSize,
          .map_height = kSize,
          .level = 0,
          .x = std::uint32_t(x),
          .y = std::uint32_t(y),
          .width = kTile,
          .height = kTile,
          .data = wire::encode_half_rgb(px.data(), px.size() / 3)};
}

std::vector<wire::MapTile> tiles_of(std::uint32_t set, int maps) {
  std::vector<wire::MapTile> out;
  for (int k = 0; k < maps; ++k)
    for (int y = 0; y < kSize; y += kTile)
      for (int x = 0; x < kSize; x += kTile) out.push_back(tile_of(set, k, x, y, float(k + 1)));
  return out;
}

wire::RequestMaps phong(const std::vector<double>& shininess) {
  return map_request(shininess, kSize, Projection::AngleMap);
}

// A GGX chain from face 16 down to `last` (16x96 cubes, then 8x48, ...), in 8x8 tiles; the
// roughness per level as given.
std::vector<wire::MapTile> chain_of(std::uint32_t set, const std::vector<float>& roughness) {
  std::vector<wire::MapTile> out;
  for (std::size_t k = 0; k < roughness.size(); ++k) {
    const int face = kSize >> k, tile = std::min(kTile, face);
    for (int y = 0; y < 6 * face; y += tile)
      for (int x = 0; x < face; x += tile) {
        const std::vector<float> px(std::size_t(tile * tile * 3), float(k + 1));
        out.push_back({.map_set = set,
                       .map_index = std::uint16_t(k),
                       .projection = Projection::Cube,
                       .map_width = std::uint32_t(face),
                       .map_height = std::uint32_t(6 * face),
                       .x = std::uint32_t(x),
                       .y = std::uint32_t(y),
                       .width = std::uint32_t(tile),
                       .height = std::uint32_t(tile),
                       .data = wire::encode_half_rgb(px.data(), px.size() / 3),
                       .kind = wire::MapKind::Ggx,
                       .roughness = roughness[k]});
      }
  }
  return out;
}

wire::MapSetComplete done(std::uint32_t set, int maps) {
  return {
      .map_set = set, .maps = std::uint16_t(maps), .seconds = 0.1f, .coverage = 0.5f, .frames = 7};
}

// A set sent as its change from `base`, `tiles` level-0 tiles of it.
wire::MapSetComplete change(std::uint32_t set, int maps, std::uint32_t base, std::uint32_t tiles) {
  wire::MapSetComplete c = done(set, maps);
  c.base_set = base;
  c.tiles = tiles;
  c.frames = 8;
  return c;
}

}  // namespace

TEST(MapSetAssembler, AWholeSetCompletesWithEveryMapAndItsShininess) {
  MapSetAssembler a;
  a.expect(phong({10.0, 20.0}));
  for (const auto& t : tiles_of(3, 2)) a.add_tile(t);
  const auto set = a.complete(done(3, 2));
  ASSERT_TRUE(set);
  EXPECT_TRUE(set->complete);
  ASSERT_EQ(set->maps.size(), 2u);
  EXPECT_EQ(set->shininess, (std::vector<double>{10.0, 20.0}));
  EXPECT_EQ(set->maps[1].image.at(kSize - 1, kSize - 1).g, 2.0f);
  EXPECT_EQ(set->frames, 7u);
}

// A set resumed on a new connection after its first tiles went to the old one: the maps that
// never arrived would be black with shininess 0 (arlight-client died on that); it is dropped,
// and the next whole set is used.
TEST(MapSetAssembler, ASetMissingItsFirstTilesIsDroppedAndTheNextWholeOneUsed) {
  MapSetAssembler a;
  a.expect(phong({10.0, 20.0, 30.0}));
  const auto tiles = tiles_of(4, 3);
  for (std::size_t i = 5; i < tiles.size(); ++i)
    a.add_tile(tiles[i]);  // map 0 and part of map 1 lost
  EXPECT_FALSE(a.complete(done(4, 3)));
  // Fewer maps than MapSetComplete counts: dropped too.
  for (const auto& t : tiles_of(5, 2)) a.add_tile(t);
  EXPECT_FALSE(a.complete(done(5, 3)));
  for (const auto& t : tiles_of(6, 3)) a.add_tile(t);
  const auto set = a.complete(done(6, 3));
  ASSERT_TRUE(set);
  EXPECT_EQ(set->shininess, (std::vector<double>{10.0, 20.0, 30.0}));
}

// Issue 36 §2: a set sent as what changed takes its other tiles from the set it names, one of
// the two newest this client completed; a change against any other, or missing one of its
// tiles (begun on an earlier connection), is not used.
TEST(MapSetAssembler, ASetOfChangesTakesTheRestFromTheSetItNames) {
  MapSetAssembler a;
  a.expect(phong({10.0, 20.0}));
  for (const auto& t : tiles_of(3, 2)) a.add_tile(t);
  const auto whole = a.complete(done(3, 2));
  ASSERT_TRUE(whole);
  a.add_tile(tile_of(4, 1, 8, 0, 9.0f));  // one tile of map 1 moved
  const auto set = a.complete(change(4, 2, 3, 1));
  ASSERT_TRUE(set);
  EXPECT_EQ(set->id, 4u);
  EXPECT_EQ(set->base_set, 3u);
  EXPECT_EQ(set->frames, 8u);
  EXPECT_EQ(set->shininess, (std::vector<double>{10.0, 20.0}));
  EXPECT_EQ(set->maps[1].image.at(8, 0).r, 9.0f);
  EXPECT_EQ(set->maps[1].image.at(15, 7).g, 9.0f);
  EXPECT_EQ(set->maps[1].image.at(7, 0).r, 2.0f);   // the base's, beside it
  EXPECT_EQ(set->maps[1].image.at(8, 8).r, 2.0f);
  EXPECT_EQ(set->maps[0].image.at(8, 0).r, 1.0f);   // a map with no change: the base's
  EXPECT_EQ(whole->maps[1].image.at(8, 0).r, 2.0f);  // the base itself is untouched

  // Nothing changed: the base's maps under the new set's number.
  const auto same = a.complete(change(5, 2, 4, 0));
  ASSERT_TRUE(same);
  EXPECT_EQ(same->maps[1].image.at(8, 0).r, 9.0f);
  // Against the second newest (4; 5 is newer): still held.
  a.add_tile(tile_of(6, 0, 0, 8, 5.0f));
  const auto older = a.complete(change(6, 2, 4, 1));
  ASSERT_TRUE(older);
  EXPECT_EQ(older->maps[0].image.at(0, 8).r, 5.0f);
  EXPECT_EQ(older->maps[1].image.at(8, 0).r, 9.0f);

  // A base no longer held (3: 5 and 6 are the newest two), one that never was, a change
  // missing one of its two tiles: dropped.
  EXPECT_FALSE(a.complete(change(7, 2, 3, 0)));
  EXPECT_FALSE(a.complete(change(8, 2, 99, 0)));
  a.add_tile(tile_of(9, 0, 0, 0, 3.0f));
  EXPECT_FALSE(a.complete(change(9, 2, 6, 2)));
  // Another request: its sets start whole, and nothing before it is a base.
  a.expect(phong({10.0, 20.0}));
  EXPECT_FALSE(a.complete(change(10, 2, 6, 0)));
  for (const auto& t : tiles_of(11, 2)) a.add_tile(t);
  EXPECT_TRUE(a.complete(done(11, 2)));
  EXPECT_TRUE(a.complete(change(12, 2, 11, 0)));
}

// A chain sent as changes: a level's first changed tile makes that level at its own size,
// even when the levels before it changed nowhere.
TEST(MapSetAssembler, AChainOfChangesKeepsEachLevelsSize) {
  MapSetAssembler a;
  a.expect(ggx_request(16, 3));
  for (const auto& t : chain_of(1, {0.0f, 0.3f, 1.0f})) a.add_tile(t);
  ASSERT_TRUE(a.complete(done(1, 3)));
  const auto chain = chain_of(2, {0.0f, 0.3f, 1.0f});
  std::vector<wire::MapTile> changed;
  for (const auto& t : chain)
    if (t.map_index == 2) changed.push_back(t);  // level 2 (4x24) only
  for (auto t : changed) {
    const std::vector<float> px(std::size_t(t.width * t.height * 3), 7.0f);
    t.data = wire::encode_half_rgb(px.data(), px.size() / 3);
    a.add_tile(t);
  }
  const auto set = a.complete(change(2, 3, 1, std::uint32_t(changed.size())));
  ASSERT_TRUE(set);
  EXPECT_EQ(set->maps[2].image.at(3, 23).r, 7.0f);
  EXPECT_EQ(set->maps[1].image.at(7, 47).r, 2.0f);
  EXPECT_EQ(set->maps[0].layout.width(), 16);
}

// A whole set that answers another request (a resumed session's set in flight for the earlier
// connection) is not used: not before this connection asked for maps (the eval test's SH-only
// client was drawn with maps under load), nor with other shininess values.
TEST(MapSetAssembler, ASetThisConnectionDidNotAskForIsNotUsed) {
  MapSetAssembler a;
  for (const auto& t : tiles_of(7, 2)) a.add_tile(t);
  EXPECT_FALSE(a.complete(done(7, 2)));  // no request yet
  a.expect(phong({10.0, 40.0}));
  for (const auto& t : tiles_of(8, 2)) a.add_tile(t);
  EXPECT_FALSE(a.complete(done(8, 2)));  // 10, 20: not what was asked
  a.expect(phong({10.0, 20.0}));
  for (const auto& t : tiles_of(9, 2)) a.add_tile(t);
  EXPECT_TRUE(a.complete(done(9, 2)));
}

// A GGX chain (issue 34 §2): whole, with as many levels as asked, each half the face of the one
// before and rising roughness from the mirror; it goes to Lighting::ggx, not the Phong maps.
TEST(MapSetAssembler, AGgxChainCompletesOnlyAsAsked) {
  MapSetAssembler a;
  a.expect(ggx_request(16, 3));
  for (const auto& t : chain_of(1, {0.0f, 0.3f, 1.0f})) a.add_tile(t);
  const auto set = a.complete(done(1, 3));
  ASSERT_TRUE(set);
  EXPECT_EQ(set->kind, wire::MapKind::Ggx);
  EXPECT_EQ(set->roughness, (std::vector<double>{0.0, double(0.3f), 1.0}));
  ASSERT_EQ(set->maps.size(), 3u);
  EXPECT_EQ(set->maps[2].layout.width(), 4);
  EXPECT_EQ(set->maps[2].image.at(3, 23).b, 3.0f);
  // Two levels where three were asked; roughness that falls; a Phong set for a chain request.
  for (const auto& t : chain_of(2, {0.0f, 0.3f})) a.add_tile(t);
  EXPECT_FALSE(a.complete(done(2, 2)));
  for (const auto& t : chain_of(3, {0.0f, 0.5f, 0.3f})) a.add_tile(t);
  EXPECT_FALSE(a.complete(done(3, 3)));
  for (const auto& t : tiles_of(4, 3)) a.add_tile(t);
  EXPECT_FALSE(a.complete(done(4, 3)));
  // Levels 0 asks for the face down to 16: one level from 16.
  a.expect(ggx_request(16));
  for (const auto& t : chain_of(5, {0.0f})) a.add_tile(t);
  EXPECT_TRUE(a.complete(done(5, 1)));

  LightingState state;
  state.expect_maps(ggx_request(16, 2));
  for (const auto& t : chain_of(6, {0.0f, 1.0f})) state.receive(wire::MapTile(t));
  EXPECT_EQ(state.receive(done(6, 2)), LightingState::Change::MapSet);
  ASSERT_TRUE(state.lighting().ggx);
  EXPECT_FALSE(state.lighting().maps);
  EXPECT_EQ(state.lighting().ggx_version, 1u);
}

// A chain asked for with specular_lights (issue 51 §1) comes with its lights; lights beside a
// chain asked for without them (it would hold them twice), or more than asked, are not used.
TEST(MapSetAssembler, AChainsLightsComeWithItOnlyAsAsked) {
  const SpecularLight sun{{0.0f, 0.6f, -0.8f}, {40.0f, 36.0f, 28.0f}, 0.0125f};
  MapSetAssembler a;
  a.expect(ggx_request(16, 2, 1));
  for (const auto& t : chain_of(1, {0.0f, 1.0f})) a.add_tile(t);
  wire::MapSetComplete with_sun = done(1, 2);
  with_sun.lights = {sun};
  const auto set = a.complete(with_sun);
  ASSERT_TRUE(set);
  EXPECT_EQ(set->lights, std::vector<SpecularLight>{sun});
  for (const auto& t : chain_of(2, {0.0f, 1.0f})) a.add_tile(t);
  with_sun.map_set = 2;
  with_sun.lights = {sun, sun};
  EXPECT_FALSE(a.complete(with_sun));
  a.expect(ggx_request(16, 2));
  for (const auto& t : chain_of(3, {0.0f, 1.0f})) a.add_tile(t);
  with_sun.map_set = 3;
  with_sun.lights = {sun};
  EXPECT_FALSE(a.complete(with_sun));
  for (const auto& t : chain_of(4, {0.0f, 1.0f})) a.add_tile(t);
  const auto whole = a.complete(done(4, 2));
  ASSERT_TRUE(whole);
  EXPECT_TRUE(whole->lights.empty());
}

TEST(LightingState, EachMessageChangesWhatItSaysAndNothingElse) {
  using Change = LightingState::Change;
  LightingState state;
  wire::Welcome welcome;
  welcome.session_id = "s1";
  EXPECT_EQ(state.receive(std::move(welcome)), Change::Welcome);
  EXPECT_EQ(state.welcome()->session_id, "s1");
  wire::LightingUpdate u;
  u.frame_sequence = 5, u.frames_processed = 4, u.coverage = 0.25f, u.frame_exposure = 0.02;
  u.sh = ShCoeffs(3);
  u.sh.c[0] = glm::dvec3(1.0);
  u.dominant_direction = {0, 1, 0};
  EXPECT_EQ(state.receive(wire::LightingUpdate(u)), Change::Update);
  const Lighting& l = state.lighting();
  EXPECT_EQ(l.sh_version, 1u);
  EXPECT_EQ(l.sh->c[0], glm::dvec3(1.0));
  EXPECT_EQ(l.frame_sequence, 5u);
  EXPECT_EQ(l.frames_processed, 4u);
  EXPECT_FLOAT_EQ(float(l.coverage), 0.25f);
  EXPECT_DOUBLE_EQ(l.frame_exposure, 0.02);
  EXPECT_EQ(l.dominant_direction, glm::vec3(0, 1, 0));
  // A frame not used says exposure 0: the last one stands.
  u.frame_sequence = 6, u.frame_exposure = 0;
  state.receive(wire::LightingUpdate(u));
  EXPECT_EQ(l.frame_sequence, 6u);
  EXPECT_DOUBLE_EQ(l.frame_exposure, 0.02);
  EXPECT_EQ(state.updates(), 2u);
  // Tiles change nothing until their set completes; a set not asked for is not used.
  for (const auto& t : tiles_of(1, 2))
    EXPECT_EQ(state.receive(wire::MapTile(t)), Change::Nothing);
  EXPECT_EQ(state.receive(done(1, 2)), Change::Nothing);
  EXPECT_FALSE(l.maps);
  state.expect_maps(client::map_request({10.0, 20.0}, 16, Projection::AngleMap));
  for (const auto& t : tiles_of(2, 2)) state.receive(wire::MapTile(t));
  EXPECT_EQ(state.receive(done(2, 2)), Change::MapSet);
  ASSERT_TRUE(l.maps);
  EXPECT_EQ(l.maps->id, 2u);
  EXPECT_EQ(l.maps_version, 1u);
  EXPECT_EQ(state.map_sets(), 1u);
  EXPECT_EQ(l.sh_version, 2u);  // the set left the SH as it was
  EXPECT_EQ(state.receive(wire::Error{wire::ErrorCode::Busy, "slow"}), Change::Error);
  EXPECT_EQ(state.error()->second, "slow");
  EXPECT_EQ(state.receive(wire::ExposureAdvice{.exposure = 0.004}), Change::ExposureAdvice);
  EXPECT_DOUBLE_EQ(state.exposure_advice()->exposure, 0.004);
  EXPECT_EQ(state.receive(wire::Pong{}), Change::Nothing);
}

// Issue 37 §1: the frame advice both clients follow. None: every frame at the camera's size;
// 320x240 at 10 a second from a 640x480 camera at 30: every third frame, halved; an advised size
// that is not the camera's over a power of two: the camera's.
namespace {
wire::LightingUpdate advice(std::uint16_t width, std::uint16_t height, float fps) {
  wire::LightingUpdate u;
  u.advised_width = width, u.advised_height = height, u.advised_fps = fps;
  return u;
}
}  // namespace

TEST(FramePacer, SendsTheAdvisedSizeAtTheAdvisedRate) {
  client::FramePacer pacer;
  int frame = 3000;  // the camera's clock: frame / 30 s
  const auto run = [&](int frames) {
    int sent = 0, reduction = 0;
    for (int k = 0; k < frames; ++k) {
      const double t = ++frame / 30.0;
      const client::FramePacer::Decision d = pacer.frame_due(t, 640, 480, 30.0);
      if (!d.send) continue;
      ++sent, reduction = d.reduction;
      pacer.sent(t);
    }
    return std::pair{sent, reduction};
  };
  EXPECT_EQ(run(30), (std::pair{30, 1}));
  EXPECT_EQ(pacer.held_back(), 0u);
  pacer.advise(advice(320, 240, 10));
  EXPECT_EQ(run(30), (std::pair{10, 2}));
  EXPECT_EQ(pacer.held_back(), 20u);
  pacer.advise(advice(160, 120, 30));
  EXPECT_EQ(run(30), (std::pair{30, 4}));
  pacer.advise(advice(200, 150, 0));
  EXPECT_EQ(run(30), (std::pair{30, 1}));
}

// Issue 36 §1: at most two frames in flight. A third waits for an update that answers one (an
// update answers every frame up to its sequence, dropped ones included); one never answered
// counts as lost after kInFlightTimeout; a new connection forgets what the old one had in
// flight; no limit: nothing is held for it.
TEST(FramePacer, HoldsTheNewestFrameWhileTwoAreUnanswered) {
  client::FramePacer pacer;
  pacer.limit_in_flight(2);
  std::uint64_t sequence = 0;
  double t = 100.0;
  const auto offer = [&] {  // the camera's next frame: sent when due
    t += 1.0 / 30.0;
    if (!pacer.frame_due(t, 640, 480, 30.0).send) return false;
    pacer.sent(t, ++sequence);
    return true;
  };
  const auto answer = [&](std::uint64_t s) {
    wire::LightingUpdate u;
    u.frame_sequence = s;
    pacer.advise(u);
  };
  EXPECT_TRUE(offer());
  EXPECT_TRUE(offer());
  EXPECT_FALSE(offer());
  EXPECT_FALSE(offer());
  EXPECT_EQ(pacer.held_in_flight(), 2u);
  EXPECT_EQ(pacer.held_back(), 2u);
  answer(1);
  EXPECT_EQ(pacer.in_flight(), 1);
  EXPECT_TRUE(offer());  // sequence 3
  EXPECT_FALSE(offer());
  answer(3);  // frame 2 was dropped on the way: answered too
  EXPECT_EQ(pacer.in_flight(), 0);
  EXPECT_TRUE(offer());
  EXPECT_TRUE(offer());
  EXPECT_FALSE(offer());
  t += client::FramePacer::kInFlightTimeout;  // no update for two seconds: taken as lost
  EXPECT_TRUE(offer());
  EXPECT_TRUE(offer());
  EXPECT_FALSE(offer());
  pacer.forget_in_flight();  // reconnected
  EXPECT_TRUE(offer());
  pacer.limit_in_flight(0);
  const std::uint64_t held = pacer.held_in_flight();
  for (int k = 0; k < 10; ++k) EXPECT_TRUE(offer());
  EXPECT_EQ(pacer.held_in_flight(), held);
}

// Issue 36 §1: JPEG size follows the link. With the daemon's byte budget, frames go at the
// highest quality whose frames are expected within it, learnt from the frames' real sizes (here
// a camera whose bytes fall with quality faster than the pacer's table assumes), and it holds
// there without swinging; a wider link takes the quality back up, a narrower one down to the
// floor, no advice to the top.
TEST(FramePacer, TheJpegQualityFollowsTheAdvisedFrameBytes) {
  client::FramePacer pacer;
  // This camera's 320x240 frames: 24 kB at quality 90, and relatively smaller below than
  // FramePacer::kRelativeBytes says (a rendered room's JPEGs, measured).
  const auto bytes_at = [](int quality) {
    const std::map<int, double> relative{{90, 1.0}, {80, 0.594}, {70, 0.463}, {60, 0.39},
                                         {50, 0.347}};
    return std::size_t(24000 * relative.at(quality));
  };
  double t = 10.0;
  std::vector<int> qualities;
  std::vector<std::size_t> sizes;
  const auto run = [&](std::uint32_t budget, int frames) {
    wire::LightingUpdate u = advice(320, 240, 30);
    u.advised_frame_bytes = budget;
    pacer.advise(u);
    qualities.clear(), sizes.clear();
    for (int k = 0; k < frames; ++k) {
      const client::FramePacer::Decision d = pacer.frame_due(t += 1.0 / 30, 640, 480, 30.0);
      EXPECT_TRUE(d.send);
      EXPECT_EQ(d.reduction, 2);
      pacer.sent(t);
      pacer.encoded(bytes_at(d.quality), 320, 240, d.quality);
      qualities.push_back(d.quality), sizes.push_back(bytes_at(d.quality));
    }
  };
  run(0, 5);  // no advice yet
  EXPECT_EQ(qualities, std::vector<int>(5, 90));
  run(12500, 20);  // 3 Mbit/s: q80's 14.3 kB is over, q70's 11.1 kB fits
  EXPECT_EQ(qualities.back(), 70);
  EXPECT_EQ(pacer.quality(), 70);
  for (std::size_t k = 2; k < sizes.size(); ++k) {
    EXPECT_LE(sizes[k], 12500u) << k;
    EXPECT_EQ(qualities[k], 70) << "settled, not swinging: " << k;
  }
  run(100000, 3);  // a wider link
  EXPECT_EQ(qualities.back(), 90);
  run(2000, 3);  // narrower than the lowest quality's frames: the floor
  EXPECT_EQ(qualities.back(), 50);
  run(0, 1);  // the advice withdrawn
  EXPECT_EQ(qualities.back(), 90);
}

// Issue 36 §5: the frames a fail-over would lose. Kept while no checkpoint holds them, sent again
// after a resume from the one after the Welcome's last_sequence, in order, and frames due without
// a daemon wait behind them; past the size limit the oldest go.
TEST(UnsavedFrames, KeepsWhatNoCheckpointHoldsAndSendsItAgainAfterAResume) {
  client::UnsavedFrames kept(1000);  // bytes
  const std::vector<std::uint8_t> jpeg(100, 7);
  const auto keep = [&](std::uint64_t s, bool sent) { kept.keep(s, {double(s)}, 8, 8, jpeg, sent); };
  for (std::uint64_t s = 1; s <= 6; ++s) keep(s, true);
  EXPECT_FALSE(kept.waiting());
  kept.saved(3);  // a checkpoint with frames 1-3
  EXPECT_EQ(kept.size(), 3u);
  keep(7, false), keep(8, false);  // no daemon
  kept.saved(8);  // forgets 4-6; 7 and 8 never went, so no checkpoint has them, whatever it says
  EXPECT_EQ(kept.size(), 2u);
  EXPECT_EQ(kept.waiting_unsent(), 2u);
  // A fail-over: frames 3-6 sent, 7 due without a daemon; the resumed session holds 1-4.
  client::UnsavedFrames lost(1000);
  const auto keep2 = [&](std::uint64_t s, bool sent) { lost.keep(s, {double(s)}, 8, 8, jpeg, sent); };
  for (std::uint64_t s = 1; s <= 6; ++s) keep2(s, true);
  lost.saved(2);
  keep2(7, false);
  lost.welcomed(4);  // the resumed session holds 1-4
  std::vector<std::uint64_t> order;
  while (const client::UnsavedFrames::Frame* f = lost.next_waiting()) {
    order.push_back(f->sequence);
    EXPECT_EQ(f->info.timestamp, double(f->sequence));
    EXPECT_EQ(f->jpeg, jpeg);
    lost.sent_next();
  }
  EXPECT_EQ(order, (std::vector<std::uint64_t>{5, 6, 7}));
  EXPECT_EQ(lost.resent(), 2u);  // 5 and 6 went twice; 7 once
  EXPECT_EQ(lost.waiting_unsent(), 0u);
  // The size limit: ten frames of 100 bytes fit, the eleventh drops the oldest.
  for (std::uint64_t s = 8; s <= 20; ++s) keep2(s, s % 2 == 0 && !lost.waiting());
  EXPECT_LE(lost.bytes(), 1000u);
  EXPECT_EQ(lost.size(), 10u);
  EXPECT_EQ(lost.given_up(), 6u);  // 5, 6, 7 and 8-10
  EXPECT_GT(lost.given_up_unsent(), 0u);
}

// Sending again goes at the daemon's pace: two frames in flight even without a limit.
TEST(FramePacer, FramesSentAgainWaitForAnswers) {
  client::FramePacer pacer;  // no in-flight limit for new frames
  EXPECT_TRUE(pacer.may_resend(1.0));
  pacer.sent(1.0, 5);
  EXPECT_TRUE(pacer.may_resend(1.0));
  pacer.sent(1.0, 6);
  EXPECT_FALSE(pacer.may_resend(1.0));
  wire::LightingUpdate u;
  u.frame_sequence = 5;
  pacer.advise(u);
  EXPECT_TRUE(pacer.may_resend(1.0));
  pacer.sent(1.0, 7);
  EXPECT_FALSE(pacer.may_resend(1.5));
  EXPECT_TRUE(pacer.may_resend(1.0 + client::FramePacer::kInFlightTimeout + 0.1));  // lost
}
