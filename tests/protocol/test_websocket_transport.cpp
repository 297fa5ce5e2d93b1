// The WebSocket transport under MessageStream over real loopback connections (plain ws; the
// daemon's wss is the same transport over TLS, tested end to end in tests/e2e): messages in
// order both ways with permessage-deflate, and each kind of bad message refused with the stream
// still able to answer with an Error and close with a WebSocket close frame.
#include <gtest/gtest.h>

#include <boost/asio/executor_work_guard.hpp>
#include <boost/asio/io_context.hpp>
#include <boost/asio/strand.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/websocket.hpp>
#include <chrono>
#include <condition_variable>
#include <mutex>
#include <thread>

#include "arlight/protocol/websocket_transport.hpp"
#include "stream_seen.hpp"

namespace arlight {
namespace {

namespace asio = boost::asio;
namespace beast = boost::beast;
namespace websocket = beast::websocket;
using asio::ip::tcp;
using namespace std::chrono_literals;

using test::Seen;

// A server MessageStream on a WebSocket transport that answered a real upgrade request, and the
// client's WebSocket (handshake done) for the test to drive.
struct WebSocketPair {
  asio::io_context io;
  asio::executor_work_guard<asio::io_context::executor_type> work = asio::make_work_guard(io);
  std::thread thread;
  std::shared_ptr<wire::MessageStream> server;
  std::optional<wire::WebSocket> client;
  std::string extensions;  // what the server's 101 answer agreed to

  // `deflate`: the client offers permessage-deflate, as a browser does.
  explicit WebSocketPair(Seen& at_server, wire::WireLimits limits = {}, bool deflate = true) {
    thread = std::thread([this] { io.run(); });
    tcp::acceptor acceptor(io, tcp::endpoint(asio::ip::make_address("127.0.0.1"), 0));
    const auto ep = acceptor.local_endpoint();
    std::thread client_side([&] {
      wire::WebSocket ws(asio::make_strand(io));
      beast::get_lowest_layer(ws).connect(ep);
      wire::configure_websocket(ws, /*server=*/false);
      // As a browser does (a native client does not): offer permessage-deflate.
      websocket::permessage_deflate offer;
      offer.client_enable = deflate;
      ws.set_option(offer);
      websocket::response_type response;
      ws.handshake(response, "127.0.0.1", "/ws");
      extensions = std::string(response[beast::http::field::sec_websocket_extensions]);
      client.emplace(std::move(ws));
    });
    tcp::socket socket = acceptor.accept(asio::make_strand(io));
    beast::flat_buffer buffer;
    wire::UpgradeRequest request;
    beast::http::read(socket, buffer, request);
    server = std::make_shared<wire::MessageStream>(
        wire::make_websocket_transport(wire::WebSocket(beast::tcp_stream(std::move(socket))),
                                       std::move(request)),
        wire::MessageStream::Options{limits, 0});
    server->start(at_server.handlers());
    client_side.join();
  }
  ~WebSocketPair() {
    if (client) {
      beast::error_code ec;
      beast::get_lowest_layer(*client).socket().close(ec);
    }
    work.reset();
    io.stop();
    thread.join();
  }
};

// The next binary message the client reads, decoded.
wire::Message read_message(wire::WebSocket& ws) {
  beast::flat_buffer buffer;
  ws.read(buffer);
  EXPECT_TRUE(ws.got_binary());
  const auto* p = static_cast<const std::uint8_t*>(buffer.data().data());
  return wire::decode(std::span(p, buffer.size()));
}

TEST(WebSocketTransport, CarriesMessagesInOrderBothWays) {
  Seen at_server, at_client;
  WebSocketPair pair(at_server);
  auto client = std::make_shared<wire::MessageStream>(
      wire::make_websocket_transport(std::move(*pair.client)), wire::MessageStream::Options{});
  pair.client.reset();
  client->start(at_client.handlers());
  wire::CameraFrame frame;
  frame.sequence = 5, frame.width = 2000, frame.height = 1000;
  for (std::size_t i = 0; i < (3u << 20); ++i) frame.data.push_back(std::uint8_t(i * 7919 >> 5));
  for (std::uint64_t i = 0; i < 100; ++i) client->send(wire::Ping{i});
  client->send(frame);  // 3 MiB: many WebSocket reads of 64 KiB
  pair.server->send(wire::Pong{1});
  ASSERT_TRUE(at_server.wait([&] { return at_server.messages.size() == 101; }));
  ASSERT_TRUE(at_client.wait([&] { return at_client.messages.size() == 1; }));
  for (std::uint64_t i = 0; i < 100; ++i)
    EXPECT_EQ(std::get<wire::Ping>(at_server.messages[i]).nonce, i);
  EXPECT_TRUE(at_server.messages[100] == wire::Message(frame));
  EXPECT_EQ(std::get<wire::Pong>(at_client.messages[0]).nonce, 1u);
  client->close();
  ASSERT_TRUE(at_server.wait([&] { return at_server.closed.has_value(); }));
  EXPECT_FALSE(at_server.bad);
}

// Issue 36 §1: as MessageStream's own framing (test_message_stream.cpp), a message the browser
// sends in pieces over a slow uplink arrives over their time: here fragments 20 ms apart
// (uncompressed: Beast's deflate would hold every fragment back until the last).
TEST(WebSocketTransport, AMessagesArrivalIsTheBytesAfterItsFirstReadOverTheirTime) {
  Seen at_server;
  WebSocketPair pair(at_server, {}, /*deflate=*/false);
  at_server.stream = pair.server.get();
  const std::vector<std::uint8_t> envelope = test::encoded_frame(40000);
  constexpr std::size_t kPiece = 4000;
  for (std::size_t at = 0; at < envelope.size(); at += kPiece) {
    if (at > 0) std::this_thread::sleep_for(20ms);
    const std::size_t n = std::min(kPiece, envelope.size() - at);
    pair.client->write_some(at + n == envelope.size(), asio::buffer(envelope.data() + at, n));
  }
  ASSERT_TRUE(at_server.wait([&] { return at_server.messages.size() == 1; }));
  const wire::Arrival a = at_server.arrivals[0];
  EXPECT_GE(a.bytes_after_first, envelope.size() - 2 * kPiece);
  EXPECT_GT(a.seconds, 9 * 0.020 * 0.9);
  EXPECT_LT(a.seconds, 1.0);
}

// Each bad message is refused with its fault; the server can still send its Error, then closes
// with a WebSocket close frame (the browser sees code 1000, not an abnormal 1006).
TEST(WebSocketTransport, RefusesTextOversizeEmptyAndInflatedBombsThenClosesCleanly) {
  struct Case {
    const char* name;
    bool text;
    std::vector<std::uint8_t> bytes;
    wire::Fault fault;
  };
  std::vector<Case> cases = {
      {"text", true, {'h', 'i'}, wire::Fault::Malformed},
      {"oversize", false, std::vector<std::uint8_t>((1u << 20) + 1, 0x37), wire::Fault::OverLimit},
      {"empty", false, {}, wire::Fault::Malformed},
      // 32 MiB of zeros deflate to a few KiB on the wire: bounded after inflation.
      {"deflate bomb", false, std::vector<std::uint8_t>(32u << 20, 0), wire::Fault::OverLimit},
      {"garbage", false, {1, 2, 3, 4, 5, 6, 7, 8}, wire::Fault::NotArlight},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    Seen at_server;
    WebSocketPair pair(at_server, {.max_message_bytes = 1u << 20});
    EXPECT_NE(pair.extensions.find("permessage-deflate"), std::string::npos) << pair.extensions;
    wire::WebSocket& ws = *pair.client;
    ws.text(c.text);
    beast::error_code ec;
    ws.write(asio::buffer(c.bytes), ec);
    ASSERT_TRUE(at_server.wait([&] { return at_server.bad.has_value(); }));
    EXPECT_EQ(at_server.bad->fault(), c.fault) << at_server.bad->what();
    pair.server->send(wire::Error{at_server.bad->code(), at_server.bad->what()});
    pair.server->close_after_sending();
    const wire::Message answer = read_message(ws);
    ASSERT_TRUE(std::holds_alternative<wire::Error>(answer));
    EXPECT_EQ(std::get<wire::Error>(answer).code, at_server.bad->code());
    beast::flat_buffer rest;
    ws.read(rest, ec);
    EXPECT_EQ(ec, websocket::error::closed) << ec.message();
    EXPECT_EQ(ws.reason().code, websocket::close_code::normal);
    ASSERT_TRUE(at_server.wait([&] { return at_server.closed.has_value(); }));
  }
}

}  // namespace
}  // namespace arlight
