// MessageStream over a real loopback TCP connection: messages in order both ways, framing
// refused before allocation, orderly close after an Error, the send queue's bound, map sets as
// bulk data behind control messages and within what the path can carry.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <boost/asio/connect.hpp>
#include <boost/asio/executor_work_guard.hpp>
#include <boost/asio/io_context.hpp>
#include <boost/asio/read.hpp>
#include <boost/asio/write.hpp>
#include <chrono>
#include <condition_variable>
#include <mutex>
#include <thread>

#include "arlight/protocol/message_stream.hpp"
#include "send_path.hpp"
#include "stream_seen.hpp"

namespace arlight {
namespace {

namespace asio = boost::asio;
using asio::ip::tcp;
using namespace std::chrono_literals;

using test::Seen;

// A connected pair of sockets on loopback, with an io thread.
struct Loopback {
  asio::io_context io;
  asio::executor_work_guard<asio::io_context::executor_type> work = asio::make_work_guard(io);
  tcp::socket server{io}, client{io};
  std::thread thread;

  Loopback() {
    tcp::acceptor acceptor(io, tcp::endpoint(asio::ip::make_address("127.0.0.1"), 0));
    client.connect(acceptor.local_endpoint());
    server = acceptor.accept();
    thread = std::thread([this] { io.run(); });
  }
  ~Loopback() {
    work.reset();
    io.stop();
    thread.join();
  }
};

// For state no handler reports (the queue drains on the io thread).
template <class P>
bool eventually(P pred) {
  for (auto end = std::chrono::steady_clock::now() + 10s; std::chrono::steady_clock::now() < end;
       std::this_thread::sleep_for(5ms))
    if (pred()) return true;
  return pred();
}

std::shared_ptr<wire::MessageStream> stream(tcp::socket& s, wire::WireLimits limits = {},
                                            std::size_t max_queued = 0) {
  return std::make_shared<wire::MessageStream>(wire::make_tcp_transport(std::move(s)),
                                               wire::MessageStream::Options{limits, max_queued});
}

TEST(MessageStream, CarriesMessagesInOrderBothWays) {
  Loopback net;
  Seen at_server, at_client;
  auto server = stream(net.server), client = stream(net.client);
  server->start(at_server.handlers());
  client->start(at_client.handlers());
  wire::CameraFrame frame;
  frame.sequence = 5, frame.width = 2000, frame.height = 1000;
  frame.data.assign(3u << 20, 0x5a);  // a large JPEG-sized payload, many TCP segments
  for (std::uint64_t i = 0; i < 100; ++i) client->send(wire::Ping{i});
  client->send(frame);
  server->send(wire::Pong{1});
  ASSERT_TRUE(at_server.wait([&] { return at_server.messages.size() == 101; }));
  ASSERT_TRUE(at_client.wait([&] { return at_client.messages.size() == 1; }));
  for (std::uint64_t i = 0; i < 100; ++i)
    EXPECT_EQ(std::get<wire::Ping>(at_server.messages[i]).nonce, i);
  EXPECT_TRUE(at_server.messages[100] == wire::Message(frame));
  EXPECT_EQ(std::get<wire::Pong>(at_client.messages[0]).nonce, 1u);
  EXPECT_EQ(client->queued_bytes(), 0u);
  client->close();
  ASSERT_TRUE(at_server.wait([&] { return at_server.closed.has_value(); }));
  EXPECT_FALSE(at_server.bad);
}

// Issue 36 §1 (the frame advice's byte budget): a message's arrival is the bytes after its first
// read over the time to its last. A frame dribbled out 4 kB every 20 ms (a ~200 kB/s uplink)
// reads as that; one written at once on loopback as far faster, or as nothing (there whole).
TEST(MessageStream, AMessagesArrivalIsTheBytesAfterItsFirstReadOverTheirTime) {
  Loopback net;
  Seen at_server;
  auto server = stream(net.server);
  at_server.stream = server.get();
  server->start(at_server.handlers());
  const std::vector<std::uint8_t> envelope = test::encoded_frame(40000);
  const auto header = wire::frame_header(envelope.size());
  asio::write(net.client, asio::buffer(header));
  constexpr std::size_t kPiece = 4000;
  for (std::size_t at = 0; at < envelope.size(); at += kPiece) {
    if (at > 0) std::this_thread::sleep_for(20ms);
    asio::write(net.client,
                asio::buffer(envelope.data() + at, std::min(kPiece, envelope.size() - at)));
  }
  asio::write(net.client, asio::buffer(header));
  asio::write(net.client, asio::buffer(envelope));
  ASSERT_TRUE(at_server.wait([&] { return at_server.messages.size() == 2; }));
  const wire::Arrival slow = at_server.arrivals[0], fast = at_server.arrivals[1];
  EXPECT_GE(slow.bytes_after_first, envelope.size() - 2 * kPiece);
  EXPECT_LE(slow.bytes_after_first, envelope.size());
  EXPECT_GT(slow.seconds, 9 * 0.020 * 0.9);
  EXPECT_LT(slow.seconds, 1.0);  // generous: a busy machine's scheduling
  // Whole at its first read (nothing to tell), or read in pieces that came far faster.
  if (fast.bytes_after_first > 0)
    EXPECT_GT(double(fast.bytes_after_first) / std::max(fast.seconds, 1e-3),
              20 * double(slow.bytes_after_first) / slow.seconds);
}

TEST(MessageStream, RefusesAnOversizeHeaderAndGarbage) {
  for (const auto& [bytes, fault] : std::vector<std::pair<std::vector<std::uint8_t>, wire::Fault>>{
           {{0, 0, 0, 0x40}, wire::Fault::OverLimit},  // 1 GiB announced: nothing allocated
           {{8, 0, 0, 0, 1, 2, 3, 4, 5, 6, 7, 8}, wire::Fault::NotArlight},
           {{0, 0, 0, 0}, wire::Fault::Malformed}}) {
    Loopback net;
    Seen at_server, at_client;
    auto server = stream(net.server, {.max_message_bytes = 1u << 20});
    auto client = stream(net.client);
    server->start(at_server.handlers());
    client->start(at_client.handlers());
    client->send_unframed(bytes);
    ASSERT_TRUE(at_server.wait([&] { return at_server.bad.has_value(); }));
    EXPECT_EQ(at_server.bad->fault(), fault) << at_server.bad->what();
    // The handler decides what follows: here an Error and an orderly close.
    server->send(wire::Error{at_server.bad->code(), at_server.bad->what()});
    server->close_after_sending();
    ASSERT_TRUE(at_client.wait([&] { return at_client.closed.has_value(); }));
    ASSERT_EQ(at_client.messages.size(), 1u);
    EXPECT_EQ(std::get<wire::Error>(at_client.messages[0]).code, at_server.bad->code());
  }
}

TEST(MessageStream, APeerThatDoesNotReadOverflowsTheBoundedQueue) {
  Loopback net;
  Seen at_server;
  auto server = stream(net.server, {}, 4u << 20);
  server->start(at_server.handlers());
  // net.client is a bare socket that never reads.
  wire::MapTile tile{1, 0, 1.0f, Projection::AngleMap, 64, 64, 0, 0, 0, 64, 64, {}};
  tile.data.assign(1u << 20, 1);
  for (int i = 0; i < 64; ++i) server->send(tile);
  ASSERT_TRUE(at_server.wait([&] { return at_server.overflows > 0; }));
  server->close();
  ASSERT_TRUE(at_server.wait([&] { return at_server.closed.has_value(); }));
  EXPECT_TRUE(eventually([&] { return server->queued_bytes() == 0; }));
}

// Issue 36 §1: nothing the client needs now waits behind bulk data. To a peer that reads late,
// a LightingUpdate sent after a map set's tiles arrives ahead of the tiles still queued, and a
// newer set replaces what of the older one has not been written.
// A set being written is finished; one not begun is replaced by a newer one (issue 36 §1, §3).
TEST(MessageStream, UpdatesGoAheadOfTilesAndANewerSetReplacesTheQueuedOne) {
  Loopback net;
  Seen at_server, at_client;
  auto server = stream(net.server);
  server->start(at_server.handlers());
  wire::MapTile tile{1, 0, 1.0f, Projection::AngleMap, 64, 64, 0, 0, 0, 64, 64, {}};
  tile.data.assign(1u << 20, 1);  // 1 MiB: a few fill the sockets' buffers
  const auto encoded = [](const wire::Message& m) {
    return std::make_shared<const std::vector<std::uint8_t>>(wire::encode(m));
  };
  constexpr int kTiles = 40;
  const auto send_set = [&](std::uint32_t set) {
    tile.map_set = set;
    for (int i = 0; i < kTiles; ++i) server->send_bulk(encoded(tile), 0, set);
    server->send_bulk(encoded(wire::MapSetComplete{set, 1, 0.1f, 0.5f, 3}), 0, set);
  };
  send_set(1);  // begun at once
  wire::LightingUpdate update;
  update.frame_sequence = 7;
  server->send(update);
  send_set(2);  // waits whole behind set 1 ...
  send_set(3);  // ... and is replaced by set 3
  // Only now does the client read.
  ASSERT_TRUE(eventually([&] { return server->bulk_replaced() > 0; }));
  // What a set sent now would be sent against (issue 36 §2): set 1, the one begun.
  EXPECT_EQ(server->bulk_begun(0, 5s), std::optional<std::uint64_t>(1));
  EXPECT_EQ(server->bulk_begun(1, 5s), std::optional<std::uint64_t>(0));  // another lane
  auto client = stream(net.client);
  client->start(at_client.handlers());
  const auto completed = [&](std::uint32_t set) {
    for (const wire::Message& m : at_client.messages)
      if (const auto* c = std::get_if<wire::MapSetComplete>(&m); c && c->map_set == set)
        return true;
    return false;
  };
  ASSERT_TRUE(at_client.wait([&] { return completed(3); }));
  std::lock_guard lock(at_client.mutex);
  int tiles[4] = {0, 0, 0, 0}, update_at = -1;
  for (std::size_t i = 0; i < at_client.messages.size(); ++i) {
    if (const auto* t = std::get_if<wire::MapTile>(&at_client.messages[i])) ++tiles[t->map_set];
    if (std::holds_alternative<wire::LightingUpdate>(at_client.messages[i])) update_at = int(i);
  }
  EXPECT_EQ(tiles[1], kTiles);  // the set begun, whole
  EXPECT_TRUE(completed(1));
  EXPECT_EQ(tiles[2], 0);       // the one that waited, replaced
  EXPECT_FALSE(completed(2));
  EXPECT_EQ(tiles[3], kTiles);  // the newest, whole
  EXPECT_EQ(server->bulk_replaced(), std::uint64_t(kTiles + 1));
  EXPECT_EQ(server->bulk_begun(0, 5s), std::optional<std::uint64_t>(3));
  EXPECT_GE(update_at, 0);
  EXPECT_LT(update_at, kTiles / 2);  // behind only what the sockets held, not set 1's rest
  client->close();
  server->close();
}

// Issue 36 §1/§3: tiles go only while the bytes in flight stay within the path's bandwidth-delay
// product plus 40 ms of queue — on a 5 Mbit/s link (625 kB/s) with a 1 ms round trip, 25.6 kB
// — and never less than 16 KiB; on loopback the bound is out of reach.
TEST(MessageStream, BulkInFlightFollowsThePathsRateAndRoundTrip) {
  EXPECT_EQ(wire::bulk_in_flight_limit({0, 625e3, 0.001}), 25625u);
  EXPECT_EQ(wire::bulk_in_flight_limit({0, 625e3, 0.060}), 62500u);  // a cellular 60 ms
  EXPECT_EQ(wire::bulk_in_flight_limit({0, 0.0, 0.0}), wire::kMinBulkInFlight);  // no sample yet
  EXPECT_EQ(wire::bulk_in_flight_limit({0, 1e5, 0.0}), wire::kMinBulkInFlight);
  EXPECT_GT(wire::bulk_in_flight_limit({0, 5e9, 20e-6}), std::size_t(100) << 20);

  // The kernel's view of a real connection: nothing unacknowledged once the peer has it all.
  Loopback net;
  const std::vector<std::uint8_t> bytes(100000, 7);
  asio::write(net.server, asio::buffer(bytes));
  std::vector<std::uint8_t> got(bytes.size());
  asio::read(net.client, asio::buffer(got));
  ASSERT_TRUE(eventually([&] {
    const auto path = wire::send_path(net.server.native_handle());
    return path && path->unacked == 0 && path->delivery_rate > 0;
  }));
  int pipe_ends[2];
  ASSERT_EQ(pipe(pipe_ends), 0);
  EXPECT_FALSE(wire::send_path(pipe_ends[1]));  // not a TCP socket: no bound
  EXPECT_FALSE(wire::send_path(-1));
  close(pipe_ends[0]);
  close(pipe_ends[1]);
}

TEST(MessageStream, SendsAfterTheEndAreDropped) {
  Loopback net;
  Seen at_server;
  auto server = stream(net.server);
  server->start(at_server.handlers());
  net.client.close();
  ASSERT_TRUE(at_server.wait([&] { return at_server.closed.has_value(); }));
  server->send(wire::Ping{1});
  EXPECT_TRUE(eventually([&] { return server->queued_bytes() == 0; }));
  EXPECT_EQ(server->bulk_begun(0, 5s), std::nullopt);  // ended: no set will be written
}

}  // namespace
}  // namespace arlight
