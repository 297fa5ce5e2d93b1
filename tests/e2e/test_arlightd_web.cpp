// arlightd's web port end to end: the real daemon with --web on loopback, its self-signed
// certificate, the browser client's files over HTTPS, and whole sessions over wss://.../ws
// through the same Connection code as TCP (limits, errors, tile codings, locked exposure).
#include <gtest/gtest.h>

#include <boost/asio/connect.hpp>
#include <boost/asio/io_context.hpp>
#include <boost/asio/ssl.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/ssl.hpp>
#include <boost/beast/websocket.hpp>
#include <boost/beast/websocket/ssl.hpp>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <memory>
#include <regex>
#include <thread>
#include <vector>

#include "arlight/net/client_net.hpp"
#include "arlight/protocol/recording.hpp"
#include "arlight/protocol/websocket_transport.hpp"
#include "arlight/protocol/wire.hpp"
#include "support/daemon_process.hpp"

namespace fs = std::filesystem;
using namespace arlight;
using test::DaemonProcess;
using test::kToken;
using namespace std::chrono_literals;
namespace asio = boost::asio;
namespace beast = boost::beast;
namespace http = beast::http;

namespace {

// arlightd with a web port and a web root holding a stand-in page.
struct WebDaemon {
  fs::path dir;
  std::unique_ptr<DaemonProcess> d;
  explicit WebDaemon(const std::string& name, const std::vector<std::string>& extra = {})
      : dir(test::fresh_temp_dir(name)) {
    fs::create_directories(dir / "root");
    std::ofstream(dir / "root" / "index.html") << "<!doctype html><title>arlight</title>";
    std::vector<std::string> args{"--web", "127.0.0.1:0", "--web-root", (dir / "root").string()};
    args.insert(args.end(), extra.begin(), extra.end());
    d = std::make_unique<DaemonProcess>(dir / "daemon", args);
  }
  fs::path certificate() const { return dir / "daemon" / "data" / "tls" / "self-signed-cert.pem"; }
};

struct HttpsResult {
  int status = -1;
  std::string body, content_type, csp;
};

// One HTTPS request to the web port, trusting the daemon's certificate.
HttpsResult https_get(std::uint16_t port, const fs::path& ca, const std::string& target,
                      http::verb verb = http::verb::get) {
  asio::io_context io;
  asio::ssl::context ctx(asio::ssl::context::tls_client);
  ctx.load_verify_file(ca.string());
  ctx.set_verify_mode(asio::ssl::verify_peer);
  beast::ssl_stream<beast::tcp_stream> stream(io, ctx);
  stream.set_verify_callback(asio::ssl::host_name_verification("127.0.0.1"));
  beast::get_lowest_layer(stream).connect({asio::ip::make_address("127.0.0.1"), port});
  stream.handshake(asio::ssl::stream_base::client);
  http::request<http::empty_body> req{verb, target, 11};
  req.set(http::field::host, "127.0.0.1");
  http::write(stream, req);
  beast::flat_buffer buffer;
  http::response_parser<http::string_body> parser;
  parser.skip(verb == http::verb::head);
  http::read(stream, buffer, parser);
  const auto& res = parser.get();
  return {int(res.result_int()), res.body(), std::string(res[http::field::content_type]),
          std::string(res["Content-Security-Policy"])};
}

// A browser-like peer on /ws: TLS, the WebSocket handshake and a Hello, then whatever the test
// sends (binary or text), reading what the daemon answers.
class RawWebSocket {
 public:
  RawWebSocket(std::uint16_t port, const std::string& token = kToken) {
    ctx_.set_verify_mode(asio::ssl::verify_none);  // the TLS side is tested elsewhere here
    beast::ssl_stream<beast::tcp_stream> tls(io_, ctx_);
    beast::get_lowest_layer(tls).connect({asio::ip::make_address("127.0.0.1"), port});
    tls.handshake(asio::ssl::stream_base::client);
    ws_.emplace(std::move(tls));
    ws_->handshake("127.0.0.1", "/ws");
    ws_->binary(true);
    send(wire::encode(
        wire::Hello{wire::kProtocolVersion, "raw", "arlight-sim", token, {"maps", "jpeg"}, "", ""}));
  }
  void send(const std::vector<std::uint8_t>& bytes, bool text = false) {
    ws_->text(text);
    beast::error_code ec;
    ws_->write(asio::buffer(bytes), ec);
  }
  // The next message, or nullopt when the connection ended (`closed_normally` says how).
  std::optional<wire::Message> read() {
    beast::flat_buffer buffer;
    beast::error_code ec;
    ws_->read(buffer, ec);
    if (ec) {
      closed_normally = ec == beast::websocket::error::closed &&
                        ws_->reason().code == beast::websocket::close_code::normal;
      return std::nullopt;
    }
    const auto* p = static_cast<const std::uint8_t*>(buffer.data().data());
    return wire::decode(std::span(p, buffer.size()));
  }
  // Reads until an Error and the end; the Error's code name, or "" when none came.
  std::string error_then_close() {
    std::string code;
    while (const auto m = read())
      if (const auto* e = std::get_if<wire::Error>(&*m)) code = wire::error_code_name(e->code);
    return code;
  }
  bool closed_normally = false;

 private:
  asio::io_context io_;
  asio::ssl::context ctx_{asio::ssl::context::tls_client};
  std::optional<wire::SecureWebSocket> ws_;
};

}  // namespace

TEST(ArlightdWeb, ServesTheClientOverHttpsAndPrintsThePhoneLink) {
  WebDaemon w("web_files");
  const DaemonProcess& d = *w.d;
  ASSERT_GT(d.web(), 0);
  // The URL carries the device and token in its fragment, the QR code follows it.
  const std::string url =
      "https://127.0.0.1:" + std::to_string(d.web()) + "/#device=arlight-sim&token=" + kToken;
  EXPECT_NE(d.banner().find("phone page " + url), std::string::npos) << d.banner();
  EXPECT_NE(d.banner().find("\u2588\u2588\u2588\u2588"), std::string::npos) << "no QR code";
  ASSERT_TRUE(fs::exists(w.certificate()));

  const auto index = https_get(d.web(), w.certificate(), "/");
  EXPECT_EQ(index.status, 200);
  EXPECT_EQ(index.body, "<!doctype html><title>arlight</title>");
  EXPECT_EQ(index.content_type, "text/html; charset=utf-8");
  EXPECT_NE(index.csp.find("connect-src 'self'"), std::string::npos) << index.csp;
  EXPECT_EQ(https_get(d.web(), w.certificate(), "/index.html", http::verb::head).status, 200);
  EXPECT_EQ(https_get(d.web(), w.certificate(), "/../tokens").status, 404);
  EXPECT_EQ(https_get(d.web(), w.certificate(), "/missing.js").status, 404);
  EXPECT_EQ(https_get(d.web(), w.certificate(), "/", http::verb::post).status, 405);
  // Plain HTTP to the web port gets no page (browsers give cameras to secure pages only).
  EXPECT_EQ(test::http_get(d.web(), "/").first, -1);  // no HTTP answer at all
}

// The same frames over wss (a browser's capabilities: raw half-float tiles, no exposure) and
// over TCP (zstd tiles, also exposure:unknown, so the daemon estimates every frame's exposure
// the same way) give the same maps.
// Plain HTTPS connections count against the connection limits too (issue 36): with three
// allowed from one address, three idle keep-alive connections to the web port leave no room for
// a fourth, on either port; one closed makes room again.
TEST(ArlightdWeb, PlainHttpsConnectionsCountAgainstTheConnectionLimits) {
  WebDaemon w("web_limits", {"--max-per-address", "3"});
  const DaemonProcess& d = *w.d;
  asio::io_context io;
  asio::ssl::context ctx(asio::ssl::context::tls_client);
  ctx.set_verify_mode(asio::ssl::verify_none);
  std::vector<std::unique_ptr<beast::ssl_stream<beast::tcp_stream>>> open;
  for (int k = 0; k < 3; ++k) {
    auto& s = open.emplace_back(std::make_unique<beast::ssl_stream<beast::tcp_stream>>(io, ctx));
    beast::get_lowest_layer(*s).connect({asio::ip::make_address("127.0.0.1"), d.web()});
    s->handshake(asio::ssl::stream_base::client);  // admitted: its TLS handshake is answered
  }
  EXPECT_ANY_THROW(https_get(d.web(), w.certificate(), "/")) << "a fourth HTTPS connection";
  client::Client tcp;
  EXPECT_ANY_THROW(tcp.connect("127.0.0.1", d.port(), "arlight-sim", kToken))
      << "a protocol connection beside three HTTPS ones";
  const std::string metrics = d.admin_get("/metrics").second;
  EXPECT_NE(metrics.find("arlight_connections_refused_per_address_total 2"), std::string::npos)
      << metrics;
  open.pop_back();  // closed
  std::this_thread::sleep_for(200ms);
  EXPECT_EQ(https_get(d.web(), w.certificate(), "/").status, 200);
}

TEST(ArlightdWeb, BrowserSessionOverWssMatchesTheSameFramesOverTcp) {
  WebDaemon w("web_session");
  const DaemonProcess& d = *w.d;
  const recording::Recording rec = recording::read_recording(test::daemon_sample_recording());
  constexpr std::size_t kFrames = 30;
  const auto run = [&](bool browser) {
    client::Client c;
    if (browser) {
      c.use_websocket();
      c.use_tls({.enabled = true, .ca_file = w.certificate().string(), .verify = true});
      c.set_capabilities(
          {"maps", "jpeg", wire::kCapabilityTilesHalf, wire::kCapabilityExposureUnknown});
    } else {
      c.set_capabilities(
          {"maps", "jpeg", wire::kCapabilityTilesZstd, wire::kCapabilityExposureUnknown});
    }
    c.connect("127.0.0.1", browser ? d.web() : d.port(), "arlight-sim", kToken);
    c.send_intrinsics(rec.camera);
    for (std::size_t i = 0; i < kFrames; ++i) {
      FrameInfo f = rec.frames[i];
      f.exposure = browser ? 0.0 : 1.0 / 60.0;  // ignored: exposure:unknown
      f.gain = browser ? 0.0 : 1.0;
      c.send_jpeg_frame(i + 1, f, rec.camera.width, rec.camera.height,
                        recording::read_frame_bytes(rec, i));
      EXPECT_TRUE(c.wait_for(
          [&] {
            const auto u = c.last_update();
            return u && u->frame_sequence >= i + 1;
          },
          20s));
    }
    EXPECT_EQ(c.last_update()->frames_processed, kFrames);
    c.request_maps({1.0, 40.0}, 64);
    EXPECT_TRUE(c.wait_for(
        [&] {
          const auto m = c.last_complete_maps();
          return m && m->frames == kFrames;
        },
        60s));
    return c.last_complete_maps().value_or(client::ReceivedMapSet{});
  };
  const client::ReceivedMapSet web = run(true), tcp = run(false);
  ASSERT_EQ(web.maps.size(), 2u);
  ASSERT_EQ(tcp.maps.size(), 2u);
  for (std::size_t k = 0; k < 2; ++k) {
    const Image& a = web.maps[k].image;
    const Image& b = tcp.maps[k].image;
    const std::size_t n = std::size_t(b.width()) * std::size_t(b.height()) * 3;
    ASSERT_EQ(a.width(), b.width());
    double mean = 0, worst = 0;
    for (std::size_t i = 0; i < n; ++i) mean += b.data()[i];
    mean /= double(n);
    ASSERT_GT(mean, 0.0);
    for (std::size_t i = 0; i < n; ++i)
      worst = std::max(worst, std::abs(double(a.data()[i]) - b.data()[i]));
    EXPECT_LT(worst, 2e-3 * mean) << "map " << k;  // both arrive as the same half floats
  }
  // Without exposure:unknown a frame with no exposure is refused, not guessed.
  client::Client plain;
  plain.connect("127.0.0.1", d.port(), "arlight-sim", kToken);
  plain.send_intrinsics(rec.camera);
  FrameInfo f = rec.frames[0];
  f.exposure = 0;
  plain.send_jpeg_frame(1, f, rec.camera.width, rec.camera.height,
                        recording::read_frame_bytes(rec, 0));
  ASSERT_TRUE(plain.wait_for([&] { return plain.last_update().has_value(); }, 20s));
  EXPECT_FALSE(plain.last_update()->frame_used);
  EXPECT_NE(plain.last_update()->reason.find("exposure"), std::string::npos);
}

// Bad input over /ws gets the Error a TCP client gets, then a clean WebSocket close; a session
// on the TCP port carries on through all of it.
TEST(ArlightdWeb, BadInputOverWsGetsTheSameErrorAndCloseAsTcp) {
  WebDaemon w("web_bad");
  const DaemonProcess& d = *w.d;
  const recording::Recording rec = recording::read_recording(test::daemon_sample_recording());
  client::Client good;
  good.connect("127.0.0.1", d.port(), "arlight-sim", kToken);
  good.send_intrinsics(rec.camera);
  const auto send_frame = [&](std::uint64_t seq) {
    good.send_jpeg_frame(seq, rec.frames[seq], rec.camera.width, rec.camera.height,
                         recording::read_frame_bytes(rec, seq));
    ASSERT_TRUE(good.wait_for(
        [&] {
          const auto u = good.last_update();
          return u && u->frame_sequence >= seq;
        },
        20s));
  };
  send_frame(1);

  const auto expect = [&](const std::vector<std::uint8_t>& bytes, bool text,
                          const std::string& code) {
    SCOPED_TRACE(code);
    RawWebSocket raw(d.web());
    ASSERT_TRUE(raw.read().has_value());  // the Welcome
    raw.send(bytes, text);
    EXPECT_EQ(raw.error_then_close(), code);
    EXPECT_TRUE(raw.closed_normally);
  };
  std::vector<std::uint8_t> garbage;
  for (int i = 0; i < 64; ++i) garbage.push_back(std::uint8_t(i * 37 + 11));
  expect(garbage, false, "BadMessage");
  expect(std::vector<std::uint8_t>((16u << 20) + 1, 7), false, "TooLarge");
  expect(wire::encode(wire::Ping{1}), true, "BadMessage");     // a text message
  expect(wire::encode(wire::Welcome{}), false, "OutOfOrder");  // a server-to-client message
  {
    // A frame before the camera's intrinsics.
    wire::CameraFrame f;
    f.sequence = 1, f.info = rec.frames[0], f.width = rec.camera.width;
    f.height = rec.camera.height, f.data = recording::read_frame_bytes(rec, 0);
    expect(wire::encode(f), false, "OutOfOrder");
  }
  {
    RawWebSocket wrong(d.web(), "not-the-token");
    EXPECT_EQ(wrong.error_then_close(), "Unauthorized");
  }
  send_frame(2);
  send_frame(3);
  EXPECT_TRUE(good.connected());
  EXPECT_FALSE(good.server_error().has_value());
}
