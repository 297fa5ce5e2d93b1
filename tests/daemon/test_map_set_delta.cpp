// Map sets sent as what changed (issue 36 §2): MapSetDeltas decides, tile by tile, what a client
// holds; a set streamed against a base reaches the client as its changed tiles, which the
// client core (MapSetAssembler) makes into the same maps the watchers get whole.
#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <variant>
#include <vector>

#include "arlight/common/hdr_io.hpp"
#include "arlight/common/resample.hpp"
#include "arlight/net/map_assembly.hpp"
#include "map_set_delta.hpp"
#include "map_set_stream.hpp"

using namespace arlight;
using namespace arlight::daemon;

namespace {

using Key = MapSetDeltas::TileKey;
const Key kTile{0, 128, 128, 64, 0, 64, 64};

std::shared_ptr<const std::vector<float>> texels(float value) {
  return std::make_shared<const std::vector<float>>(64 * 64 * 3, value);
}

}  // namespace

TEST(MapSetDeltas, ATileIsSentWhenItMovedFromWhatTheClientHoldsByMoreThanTheTolerance) {
  MapSetDeltas d;
  EXPECT_EQ(d.begin(1, 0), 0u);
  EXPECT_TRUE(d.changed(kTile, texels(1.0f)));
  d.complete();
  // Against set 1: the same, and a move of 0.2 %, are held; 1 % is sent.
  EXPECT_EQ(d.begin(2, 1), 1u);
  EXPECT_FALSE(d.changed(kTile, texels(1.002f)));
  EXPECT_TRUE(d.changed(Key{1, 128, 128, 64, 0, 64, 64}, texels(1.0f)));  // not in the base
  d.complete();
  // The client holds 1.0 (the base's) for set 2, not 1.002: three moves of 0.2 % add up.
  EXPECT_EQ(d.begin(3, 2), 2u);
  EXPECT_FALSE(d.changed(kTile, texels(1.003f)));
  d.complete();
  EXPECT_EQ(d.begin(4, 3), 3u);
  EXPECT_TRUE(d.changed(kTile, texels(1.006f)));
  d.complete();
  EXPECT_EQ(d.begin(5, 4), 4u);
  EXPECT_FALSE(d.changed(kTile, texels(1.006f)));
  EXPECT_TRUE(d.changed(Key{0, 128, 128, 0, 0, 64, 64}, texels(1.0f)));  // not in the base
  std::vector<float> nan(64 * 64 * 3, 1.006f);
  nan[5] = std::nanf("");
  EXPECT_TRUE(d.changed(kTile, std::make_shared<const std::vector<float>>(nan)));
  d.complete();
  // Near black, a move below half floats' smallest normal is no change.
  EXPECT_EQ(d.begin(6, 0), 0u);
  EXPECT_TRUE(d.changed(kTile, texels(1e-6f)));
  d.complete();
  EXPECT_EQ(d.begin(7, 6), 6u);
  EXPECT_FALSE(d.changed(kTile, texels(3e-5f)));
}

TEST(MapSetDeltas, ANewConnectionOrRequestStartsWholeAndASetBegunBeforeIsNeverABase) {
  MapSetDeltas d;
  d.begin(1, 0);
  d.changed(kTile, texels(1.0f));
  d.complete();
  EXPECT_EQ(d.begin(2, 1), 1u);
  d.changed(kTile, texels(1.0f));
  d.clear();  // a new connection while set 2 streams: its tail reaches it, its head did not
  d.complete();
  EXPECT_EQ(d.held(), 0u);
  EXPECT_EQ(d.begin(3, 2), 0u);  // the connection began set 2, but its client lacks half of it
  EXPECT_EQ(d.begin(3, 9), 0u);  // never held
  EXPECT_EQ(d.begin(3, 0), 0u);
  d.changed(kTile, texels(1.0f));
  d.complete();
  // Sets older than a base are let go (the connection's newest begun set only moves on).
  for (std::uint32_t id = 4; id < 10; ++id) {
    EXPECT_EQ(d.begin(id, id - 1), id - 1);
    d.changed(kTile, texels(float(id)));
    d.complete();
  }
  EXPECT_EQ(d.held(), 2u);  // 8 and 9
  EXPECT_EQ(d.begin(10, 7), 0u);
  d.complete();
  // A slow link: set 10 is written for a long time while 11 ... 20 are computed, each
  // replacing the one queued before it; each goes against 10, which stays held.
  for (std::uint32_t id = 11; id <= 20; ++id) {
    EXPECT_EQ(d.begin(id, 10), 10u) << id;
    d.changed(kTile, texels(float(id)));
    d.complete();
  }
  EXPECT_EQ(d.held(), 3u);  // 10, 19 (it might have begun) and 20
  // Maps of another size than the base's (a chain's preview at face 128, then the full chain
  // at 256): whole, even where a tile has the base's key and values.
  EXPECT_EQ(d.begin(21, 20), 20u);
  EXPECT_EQ(d.shape({{256, 1536}}), 0u);
  EXPECT_TRUE(d.changed(kTile, texels(20.0f)));
}

// A real set streamed twice from a map that changed in one place: the second reaches the client
// as the tiles near the change, and assembled, it is the whole set within the tolerance.
TEST(MapSetDeltas, AStreamedChangeAssemblesIntoTheWholeSet) {
  EnvMap room = resample(
      load_envmap(std::string(ARLIGHT_SOURCE_DIR) + "/data/probes/venice.exr").env,
      EnvLayout::for_size(Projection::Cube, 32));
  const MapRequest request{.shininess = {1, 80, 2000}, .size = 128};
  MapSetDeltas deltas;
  client::MapSetAssembler client;
  client.expect(wire::RequestMaps{.shininess = {1, 80, 2000}, .size = 128});
  struct Streamed {
    std::vector<wire::MapTile> client, watchers;
    std::vector<wire::MapSetComplete> client_done, watchers_done;
  };
  const auto stream = [&](std::uint32_t id, std::uint32_t base_wanted) {
    Streamed s;
    MapSetJob job{.request = request, .input = room, .id = id};
    const std::uint32_t base = deltas.begin(id, base_wanted);
    EXPECT_EQ(base, base_wanted);
    stream_map_set(job, {}, [&](const wire::Message& m, Audience to) {
      const auto* t = std::get_if<wire::MapTile>(&m);
      const auto* c = std::get_if<wire::MapSetComplete>(&m);
      if (to != Audience::Watchers) {
        if (t) s.client.push_back(*t);
        if (c) s.client_done.push_back(*c);
      }
      if (to != Audience::Client) {
        if (t) s.watchers.push_back(*t);
        if (c) s.watchers_done.push_back(*c);
      }
    }, &deltas, base);
    return s;
  };
  const Streamed first = stream(1, 0);
  ASSERT_EQ(first.client_done.size(), 1u);
  EXPECT_EQ(first.client_done[0].base_set, 0u);
  EXPECT_EQ(first.client.size(), first.watchers.size());
  for (const auto& t : first.client) client.add_tile(t);
  ASSERT_TRUE(client.complete(first.client_done[0]));

  // A bright patch on one face (+X): the sharp map changes near it only.
  for (int y = 10; y < 14; ++y)
    for (int x = 10; x < 14; ++x) room.image.view().pixel(x, y)[0] += 50.0f;
  const Streamed second = stream(2, 1);
  ASSERT_EQ(second.client_done.size(), 1u);
  ASSERT_EQ(second.watchers_done.size(), 1u);
  EXPECT_EQ(second.client_done[0].base_set, 1u);
  EXPECT_EQ(second.watchers_done[0].base_set, 0u);
  std::size_t level0 = 0, coarse = 0;
  for (const auto& t : second.client) (t.level == 0 ? level0 : coarse) += 1;
  EXPECT_EQ(coarse, 0u);
  EXPECT_EQ(second.client_done[0].tiles, level0);
  EXPECT_EQ(second.watchers_done[0].tiles, 3u * 4u);  // 128² in 64² tiles, three maps
  EXPECT_GT(level0, 0u);
  EXPECT_LT(level0, 3u * 4u);
  std::printf("a bright patch: %zu of 12 tiles sent\n", level0);
  for (const auto& t : second.client) client.add_tile(t);
  const auto assembled = client.complete(second.client_done[0]);
  ASSERT_TRUE(assembled);

  client::MapSetAssembler whole;
  whole.expect(wire::RequestMaps{.shininess = {1, 80, 2000}, .size = 128});
  for (const auto& t : second.watchers) whole.add_tile(t);
  const auto truth = whole.complete(second.watchers_done[0]);
  ASSERT_TRUE(truth);
  for (std::size_t k = 0; k < 3; ++k) {
    const auto a = assembled->maps[k].image.view(), b = truth->maps[k].image.view();
    for (int y = 0; y < a.height; ++y)
      for (int x = 0; x < a.width; ++x)
        for (int c = 0; c < 3; ++c) {
          const float u = a.pixel(x, y)[c], v = b.pixel(x, y)[c];
          ASSERT_LE(std::abs(u - v), MapSetDeltas::kTolerance * std::max(std::abs(u), std::abs(v)) + 6.2e-5f)
              << "map " << k << " at " << x << "," << y;
        }
  }

  // The same map again: nothing to send but the MapSetComplete.
  const Streamed third = stream(3, 2);
  EXPECT_TRUE(third.client.empty());
  EXPECT_EQ(third.client_done[0].tiles, 0u);
  EXPECT_TRUE(client.complete(third.client_done[0]));
}
