// Watching a session (issue 35 §2, PROTOCOL.md item 1): the real arlightd on a loopback port, a
// capturing client and watchers of its session through the client library.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <regex>
#include <string>
#include <thread>

#include "arlight/net/client_messages.hpp"
#include "arlight/net/client_net.hpp"
#include "arlight/protocol/recording.hpp"
#include "support/client_frames.hpp"
#include "support/daemon_process.hpp"
#include "support/run_tool.hpp"
#include "support/sanitizer.hpp"

namespace fs = std::filesystem;
using namespace arlight;
using namespace std::chrono_literals;
using nlohmann::json;
using test::DaemonProcess;
using test::frame_gets_update;

namespace {

// The code of the ClientError a connect() throws, or "" when it connects.
std::string refusal(const DaemonProcess& d, const std::string& device, const std::string& token,
                    const std::string& session) {
  client::Client c;
  c.watch(session);
  try {
    c.connect("127.0.0.1", d.port(), device, token, "watcher");
  } catch (const client::ClientError& e) {
    return e.code();
  }
  return "";
}

double metric(const DaemonProcess& d, const std::string& name) {
  const auto [status, text] = d.admin_get("/metrics");
  std::smatch m;
  if (status != 200 || !std::regex_search(text, m, std::regex("\n" + name + " ([0-9.e+-]+)")))
    return -1;
  return std::stod(m[1]);
}

}  // namespace

TEST(Watchers, SeeTheSessionsUpdatesAndMapSetsAndChangeNothing) {
  const fs::path dir = test::fresh_temp_dir("watchers");
  DaemonProcess d(dir / "daemon", {"--max-watchers", "2"});
  const recording::Recording rec = recording::read_recording(test::daemon_sample_recording());
  client::Client phone;
  const client::Welcome welcome = phone.connect("127.0.0.1", d.port(), "arlight-sim", test::kToken);
  const std::string& id = welcome.session_id;
  std::atomic<int> sets_from_changes = 0;
  phone.on_map_set_complete = [&](const client::ReceivedMapSet& set) {
    sets_from_changes += set.base_set != 0;
  };
  phone.send_intrinsics(rec.camera);
  phone.request_maps(client::ggx_request(32, 3));
  std::uint64_t seq = 0;
  for (; seq < 12; ++seq) ASSERT_TRUE(frame_gets_update(phone, rec, seq)) << "frame " << seq;
  // The full chain once frames pause comes as what changed since the phone's last preview (issue
  // 36 §2: the same face), assembled from the tiles that moved and that set.
  ASSERT_TRUE(phone.wait_for([&] { return sets_from_changes.load() >= 1; }, 30s))
      << "no set came as changes";

  // A watcher that joins now gets the newest update and the newest complete chain at once,
  // with no frame sent.
  client::Client viewer;
  viewer.watch(id);
  viewer.set_capabilities({"maps", wire::kCapabilityTilesHalf});  // a browser's coding
  const client::Welcome seen = viewer.connect("127.0.0.1", d.port(), test::kWatchName,
                                              test::kWatchToken, "watcher");
  EXPECT_EQ(seen.session_id, id);
  EXPECT_FALSE(seen.resumed);
  ASSERT_TRUE(viewer.wait_for(
      [&] {
        const auto mine = viewer.last_complete_ggx(), theirs = phone.last_complete_ggx();
        return viewer.last_update() && mine && theirs && mine->id == theirs->id;
      },
      20s))
      << "the watcher got no update or not the phone's newest chain";
  EXPECT_EQ(viewer.last_update()->frame_sequence, phone.last_update()->frame_sequence);
  {
    const auto mine = *viewer.last_complete_ggx(), theirs = *phone.last_complete_ggx();
    ASSERT_EQ(mine.maps.size(), 3u);
    ASSERT_EQ(mine.maps.size(), theirs.maps.size());
    // The phone's newest came as what changed, the watcher's whole. Half floats both ways
    // (zstd for the phone, raw for the watcher): the same values, or within the tolerance of a
    // tile the phone kept.
    EXPECT_NE(theirs.base_set, 0u);
    for (std::size_t k = 0; k < mine.maps.size(); ++k) {
      EXPECT_EQ(mine.roughness[k], theirs.roughness[k]);
      const auto a = mine.maps[k].image.view(), b = theirs.maps[k].image.view();
      ASSERT_EQ(a.width, b.width);
      for (int y = 0; y < a.height; ++y)
        for (int x = 0; x < a.width; ++x)
          for (int c = 0; c < 3; ++c) {
            const float u = a.pixel(x, y)[c], v = b.pixel(x, y)[c];
            ASSERT_LE(std::abs(u - v), std::max(std::abs(u), std::abs(v)) / 256.0f + 6.2e-5f)
                << "level " << k << " at " << x << "," << y;
          }
    }
  }

  // Live: each frame's update reaches the watcher as it is, SH and all.
  for (const std::uint64_t end = seq + 8; seq < end; ++seq)
    ASSERT_TRUE(frame_gets_update(phone, rec, seq)) << "frame " << seq;
  ASSERT_TRUE(viewer.wait_for(
      [&] { return viewer.last_update() && viewer.last_update()->frame_sequence == seq - 1; }, 10s));
  const auto a = *viewer.last_update(), b = *phone.last_update();
  EXPECT_TRUE(static_cast<const wire::LightingUpdate&>(a) ==
              static_cast<const wire::LightingUpdate&>(b));

  // The device's own token watches too; a frame from a watcher is refused and closes it, and
  // the session carries on without it.
  client::Client own;
  own.watch(id);
  own.connect("127.0.0.1", d.port(), "arlight-sim", test::kToken, "watcher");
  own.send_jpeg_frame(1000, rec.frames[0], rec.camera.width, rec.camera.height,
                      recording::read_frame_bytes(rec, 0));
  ASSERT_TRUE(own.wait_for([&] { return own.server_error().has_value(); }, 10s));
  EXPECT_EQ(own.server_error()->first, "Unauthorized");
  EXPECT_NE(own.server_error()->second.find("a watcher sends no frames"), std::string::npos)
      << own.server_error()->second;
  ASSERT_TRUE(frame_gets_update(phone, rec, seq));
  EXPECT_EQ(phone.last_update()->frames_processed, seq + 1);  // the phone's frames, no other
  ++seq;

  // Refusals: another device's token, a wrong token, a session that is not live, both at once.
  EXPECT_EQ(refusal(d, test::kOtherDevice, test::kOtherToken, id), "Unauthorized");
  EXPECT_EQ(refusal(d, test::kWatchName, "watch-token-wrong-000000", id), "Unauthorized");
  EXPECT_EQ(refusal(d, test::kWatchName, test::kWatchToken, std::string(32, 'a')),
            "SessionNotFound");
  EXPECT_EQ(refusal(d, test::kWatchName, test::kWatchToken, "../sessions"), "BadMessage");
  // A watch token captures nothing.
  {
    client::Client c;
    EXPECT_THROW(c.connect("127.0.0.1", d.port(), test::kWatchName, test::kWatchToken), client::ClientError);
  }

  // The limit (2): the viewer and one more; the third is Busy, and counted.
  ASSERT_TRUE(phone.wait_for([&] { return metric(d, "arlight_watchers") == 1; }, 5s))
      << metric(d, "arlight_watchers");
  client::Client second;
  second.watch(id);
  second.connect("127.0.0.1", d.port(), test::kWatchName, test::kWatchToken, "watcher");
  EXPECT_EQ(refusal(d, test::kWatchName, test::kWatchToken, id), "Busy");
  EXPECT_EQ(metric(d, "arlight_watchers"), 2);
  EXPECT_EQ(metric(d, "arlight_watchers_refused_total"), 1);
  const json sessions = json::parse(d.admin_get("/sessions").second);
  ASSERT_TRUE(sessions.is_array()) << sessions.dump();
  ASSERT_EQ(sessions.size(), 1u);
  EXPECT_EQ(sessions[0]["watchers"], 2);
  EXPECT_EQ(sessions[0]["frames_processed"], seq);
}

// A session whose client streams the thesis's Phong maps (the phone page's plastic): its
// watchers get a GGX chain of their own (256 a face, what three.js samples), computed in turn
// with the client's sets and sent to them alone.
TEST(Watchers, GetAGgxChainWhenTheClientStreamsNone) {
  const fs::path dir = test::fresh_temp_dir("watchers_chain");
  DaemonProcess d(dir / "daemon");
  const recording::Recording rec = recording::read_recording(test::daemon_sample_recording());
  client::Client phone;
  const client::Welcome welcome = phone.connect("127.0.0.1", d.port(), "arlight-sim", test::kToken);
  phone.send_intrinsics(rec.camera);
  phone.request_maps({1, 10, 80}, 32, Projection::LatLong);
  std::uint64_t seq = 0;
  for (; seq < 10; ++seq) ASSERT_TRUE(frame_gets_update(phone, rec, seq)) << "frame " << seq;
  // The room settles: no frame comes, yet the first watcher gets a chain at once (a preview at
  // face 128 while frames came a moment ago), and the full one once they have paused.
  client::Client viewer;
  viewer.watch(welcome.session_id);
  viewer.connect("127.0.0.1", d.port(), test::kWatchName, test::kWatchToken, "watcher");
  // Under the sanitizers a full chain takes ~10 s, and the other tests share the cores.
  const auto slow = test::kSanitized ? 6 : 1;
  ASSERT_TRUE(viewer.wait_for(
      [&] {
        const auto c = viewer.last_complete_ggx();
        return c && c->maps[0].layout.width() == 256;
      },
      30s * slow))
      << "no full chain for the watcher";
  const auto chain = *viewer.last_complete_ggx();
  ASSERT_EQ(chain.maps.size(), 5u);  // 256 -> 16
  EXPECT_EQ(chain.maps[0].layout.width(), 256);
  EXPECT_EQ(chain.roughness[0], 0.0);
  EXPECT_EQ(chain.roughness[4], 1.0);
  // Frames again: the chain follows the map for the watcher, the client's sets go on, and the
  // client never sees a chain it did not ask for.
  const std::uint64_t chains = viewer.map_sets_completed();
  for (const std::uint64_t end = seq + 10; seq < end; ++seq)
    ASSERT_TRUE(frame_gets_update(phone, rec, seq)) << "frame " << seq;
  EXPECT_TRUE(viewer.wait_for([&] { return viewer.map_sets_completed() > chains; }, 30s * slow));
  ASSERT_TRUE(phone.wait_for([&] { return phone.last_complete_maps().has_value(); }, 30s * slow));
  EXPECT_EQ(phone.last_complete_maps()->maps.size(), 3u);
  EXPECT_FALSE(phone.last_complete_ggx().has_value());
  // Once the full sets after the pause are out, a settled room costs no more sets: the count
  // stops growing (a set that kept asking for the next would never let it).
  bool settled = false;
  for (int round = 0; round < 12 && !settled; ++round) {
    const std::uint64_t before = viewer.map_sets_completed();
    std::this_thread::sleep_for(3s * slow);
    settled = viewer.map_sets_completed() == before;
  }
  EXPECT_TRUE(settled) << viewer.map_sets_completed() << " sets and still coming";
}
