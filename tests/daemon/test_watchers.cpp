// A session's watchers (server/daemon/src/watchers.hpp): what each gets, and that one behind
// skips to the newest update and set instead of queueing stale ones.
#include <gtest/gtest.h>

#include <variant>

#include "watchers.hpp"

using namespace arlight;
using daemon::BulkGroup;
using daemon::EncodedMessage;
using daemon::WatcherSet;

namespace {

// A watcher whose connection is a list of what it was sent, with a backlog the test sets.
struct FakeWatcher {
  std::vector<wire::Message> got;
  std::size_t backlog = 0;
  bool disconnected = false;

  WatcherSet::Watcher watcher(wire::TileCoding coding = wire::TileCoding::ZstdHalf) {
    WatcherSet::Watcher w;
    w.send = [this](EncodedMessage m, std::optional<BulkGroup>) { got.push_back(wire::decode(*m)); };
    w.backlog = [this] { return backlog; };
    w.coding = coding;
    w.disconnect = [this] { disconnected = true; };
    return w;
  }
  template <class T>
  std::vector<T> all() const {
    std::vector<T> out;
    for (const auto& m : got)
      if (const auto* t = std::get_if<T>(&m)) out.push_back(*t);
    return out;
  }
};

EncodedMessage encoded(const wire::Message& m) {
  return std::make_shared<const std::vector<std::uint8_t>>(wire::encode(m));
}

void publish(WatcherSet& set, const wire::Message& m) { set.publish(m, encoded(m)); }

wire::LightingUpdate update(std::uint64_t sequence) {
  wire::LightingUpdate u;
  u.frame_sequence = sequence;
  u.sh = ShCoeffs(1);
  u.sh.c[0] = glm::dvec3(double(sequence), 0.5, 0.25);
  return u;
}

wire::MapTile tile(std::uint32_t set, std::uint32_t x, float value,
                   wire::TileCoding coding = wire::TileCoding::ZstdHalf) {
  const std::vector<float> rgb(4 * 4 * 3, value);
  wire::MapTile t;
  t.map_set = set;
  t.map_width = 8, t.map_height = 4;
  t.x = x, t.width = 4, t.height = 4;
  t.data = wire::encode_half_rgb(rgb.data(), 16, coding);
  t.coding = coding;
  return t;
}

// A whole set of two tiles, with progress between them.
void publish_set(WatcherSet& set, std::uint32_t id, float value) {
  publish(set, wire::Progress{id, 0, 2});
  publish(set, tile(id, 0, value));
  publish(set, wire::Progress{id, 1, 2});
  publish(set, tile(id, 4, value));
  publish(set, wire::MapSetComplete{id, 1, 0.1f, 0.5f, 10});
}

const wire::Message kWelcome = [] {
  wire::Welcome w;
  w.session_id = "0123456789abcdef0123456789abcdef";
  return w;
}();

}  // namespace

TEST(WatcherSet, AWatcherGetsUpdatesAndSetsButNotTheClientsOwnMessages) {
  WatcherSet set(4);
  FakeWatcher a;
  ASSERT_NE(set.add(a.watcher(), encoded(kWelcome)), 0u);
  ASSERT_EQ(a.got.size(), 1u);  // the Welcome, nothing else yet
  EXPECT_TRUE(std::holds_alternative<wire::Welcome>(a.got[0]));
  publish(set, update(1));
  publish(set, wire::ExposureAdvice{1, 0.01, 0.1f});
  publish(set, wire::Error{wire::ErrorCode::Internal, "map computation: x"});
  publish_set(set, 1, 2.0f);
  ASSERT_EQ(a.all<wire::LightingUpdate>().size(), 1u);
  EXPECT_EQ(a.all<wire::LightingUpdate>()[0], update(1));
  EXPECT_TRUE(a.all<wire::ExposureAdvice>().empty());
  EXPECT_TRUE(a.all<wire::Error>().empty());
  EXPECT_EQ(a.all<wire::Progress>().size(), 2u);
  EXPECT_EQ(a.all<wire::MapTile>().size(), 2u);
  ASSERT_EQ(a.all<wire::MapSetComplete>().size(), 1u);
  EXPECT_TRUE(set.remove(1));
  EXPECT_FALSE(set.remove(1));
  publish(set, update(2));
  EXPECT_EQ(a.all<wire::LightingUpdate>().size(), 1u);
}

TEST(WatcherSet, ALateWatcherGetsTheNewestUpdateAndCompleteSetAtOnce) {
  WatcherSet set(4);
  publish(set, update(1));
  publish_set(set, 1, 1.0f);
  publish(set, update(2));
  publish_set(set, 2, 2.0f);
  publish(set, wire::Progress{3, 0, 2});  // set 3 is under way: the late watcher waits for set 4
  publish(set, tile(3, 0, 3.0f));
  FakeWatcher late;
  ASSERT_NE(set.add(late.watcher(), encoded(kWelcome)), 0u);
  ASSERT_EQ(late.all<wire::LightingUpdate>().size(), 1u);
  EXPECT_EQ(late.all<wire::LightingUpdate>()[0].frame_sequence, 2u);
  const auto tiles = late.all<wire::MapTile>();
  ASSERT_EQ(tiles.size(), 2u);
  for (const auto& t : tiles) EXPECT_EQ(t.map_set, 2u);
  ASSERT_EQ(late.all<wire::MapSetComplete>().size(), 1u);
  EXPECT_EQ(late.all<wire::MapSetComplete>()[0].map_set, 2u);
  EXPECT_TRUE(late.all<wire::Progress>().empty());  // kept sets carry no progress
  // The rest of set 3 is not for it (it missed its start): it is owed set 3 when it completes.
  publish(set, tile(3, 4, 3.0f));
  publish(set, wire::MapSetComplete{3, 1, 0.1f, 0.5f, 10});
  const auto after = late.all<wire::MapTile>();
  ASSERT_EQ(after.size(), 4u);
  EXPECT_EQ(after[2].map_set, 3u);
  EXPECT_EQ(after[2].x, 0u);  // set 3 whole, in order
  EXPECT_EQ(after[3].x, 4u);
}

// A session may stream two kinds (its client's Phong maps, its watchers' GGX chain): a watcher
// that joins gets the newest complete set of each.
TEST(WatcherSet, ALateWatcherGetsTheNewestSetOfEachKind) {
  WatcherSet set(4);
  publish_set(set, 1, 1.0f);  // Phong
  wire::MapTile chain = tile(2, 0, 2.0f);
  chain.kind = wire::MapKind::Ggx;
  publish(set, chain);
  publish(set, wire::MapSetComplete{2, 1, 0.1f, 0.5f, 10});
  publish_set(set, 3, 3.0f);  // Phong again: the newest Phong, the chain still the newest GGX
  FakeWatcher late;
  ASSERT_NE(set.add(late.watcher(), encoded(kWelcome)), 0u);
  const auto tiles = late.all<wire::MapTile>();
  ASSERT_EQ(tiles.size(), 3u);
  EXPECT_EQ(tiles[0].map_set, 3u);
  EXPECT_EQ(tiles[0].kind, wire::MapKind::Phong);
  EXPECT_EQ(tiles[2].map_set, 2u);
  EXPECT_EQ(tiles[2].kind, wire::MapKind::Ggx);
  EXPECT_EQ(late.all<wire::MapSetComplete>().size(), 2u);
}

TEST(WatcherSet, AWatcherBehindSkipsToTheNewestInsteadOfQueueing) {
  WatcherSet set(4);
  FakeWatcher slow, fast;
  set.add(slow.watcher(), encoded(kWelcome));
  set.add(fast.watcher(), encoded(kWelcome));
  publish(set, update(1));
  slow.backlog = WatcherSet::kBehindBytes + 1;
  for (std::uint32_t s = 1; s <= 3; ++s) {
    publish(set, update(10 * s));
    publish_set(set, s, float(s));
  }
  EXPECT_EQ(fast.all<wire::MapSetComplete>().size(), 3u);
  EXPECT_EQ(fast.all<wire::LightingUpdate>().size(), 4u);
  EXPECT_EQ(slow.all<wire::LightingUpdate>().size(), 1u);  // only the one before it fell behind
  EXPECT_TRUE(slow.all<wire::MapTile>().empty());
  set.drained(1);  // still behind: nothing
  EXPECT_TRUE(slow.all<wire::MapTile>().empty());
  slow.backlog = 0;
  set.drained(1);  // caught up: the newest update and the newest set, once
  set.drained(1);
  const auto updates = slow.all<wire::LightingUpdate>();
  ASSERT_EQ(updates.size(), 2u);
  EXPECT_EQ(updates[1].frame_sequence, 30u);
  const auto tiles = slow.all<wire::MapTile>();
  ASSERT_EQ(tiles.size(), 2u);
  EXPECT_EQ(tiles[0].map_set, 3u);
  ASSERT_EQ(slow.all<wire::MapSetComplete>().size(), 1u);
  EXPECT_EQ(slow.all<wire::MapSetComplete>()[0].map_set, 3u);
  // Caught up, it follows the next set from its start.
  publish_set(set, 4, 4.0f);
  EXPECT_EQ(slow.all<wire::MapTile>().size(), 4u);
  EXPECT_EQ(slow.all<wire::Progress>().size(), 2u);
}

TEST(WatcherSet, TilesGoInTheCodingEachWatcherAccepts) {
  WatcherSet set(4);
  FakeWatcher browser, native;
  set.add(browser.watcher(wire::TileCoding::Half), encoded(kWelcome));
  set.add(native.watcher(wire::TileCoding::ZstdHalf), encoded(kWelcome));
  publish(set, tile(1, 0, 1.5f, wire::TileCoding::ZstdHalf));
  ASSERT_EQ(browser.all<wire::MapTile>().size(), 1u);
  const wire::MapTile b = browser.all<wire::MapTile>()[0], n = native.all<wire::MapTile>()[0];
  EXPECT_EQ(b.coding, wire::TileCoding::Half);
  EXPECT_EQ(n.coding, wire::TileCoding::ZstdHalf);
  std::string why;
  const auto pixels = wire::decode_half_rgb(b.data, 16, b.coding, why);
  ASSERT_TRUE(pixels) << why;
  for (float v : *pixels) EXPECT_EQ(v, 1.5f);
  EXPECT_EQ(b.map_set, n.map_set);
  EXPECT_EQ(b.x, n.x);
}

TEST(WatcherSet, TheLimitRefusesAndTheEndDisconnectsEveryone) {
  WatcherSet set(2);
  FakeWatcher a, b, c;
  EXPECT_NE(set.add(a.watcher(), encoded(kWelcome)), 0u);
  EXPECT_NE(set.add(b.watcher(), encoded(kWelcome)), 0u);
  EXPECT_EQ(set.add(c.watcher(), encoded(kWelcome)), 0u);
  EXPECT_TRUE(c.got.empty());  // refused before its Welcome
  EXPECT_EQ(set.size(), 2u);
  EXPECT_EQ(set.disconnect_all(), 2u);
  EXPECT_TRUE(a.disconnected && b.disconnected && !c.disconnected);
  EXPECT_EQ(set.size(), 0u);
}

// A contributor (issue 49 §1) takes the sets through the watchers but not the session's updates:
// their frame sequences are the session's device's, not its own.
TEST(WatcherSet, AContributorGetsTheSetsButNotTheSessionsUpdates) {
  WatcherSet set(4);
  publish(set, update(1));
  publish_set(set, 1, 2.0f);
  FakeWatcher a;
  WatcherSet::Watcher w = a.watcher();
  w.updates = false;
  ASSERT_NE(set.add(std::move(w), encoded(kWelcome)), 0u);
  EXPECT_TRUE(a.all<wire::LightingUpdate>().empty());  // not the newest update at once
  EXPECT_EQ(a.all<wire::MapSetComplete>().size(), 1u);  // the newest set, at once
  publish(set, update(2));
  publish_set(set, 2, 3.0f);
  EXPECT_TRUE(a.all<wire::LightingUpdate>().empty());
  EXPECT_EQ(a.all<wire::MapSetComplete>().size(), 2u);
  // The session ending closes it too, but it is not counted among the watchers.
  EXPECT_EQ(set.disconnect_all(), 0u);
  EXPECT_TRUE(a.disconnected);
}
