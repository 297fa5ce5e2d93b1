#include "arlight/protocol/websocket_transport.hpp"

#include <boost/asio/post.hpp>
#include <boost/beast/ssl.hpp>
#include <boost/beast/version.hpp>
#include <boost/beast/websocket.hpp>
#include <boost/beast/websocket/ssl.hpp>
#include <optional>

#include "arrival_timer.hpp"
#include "socket_options.hpp"

namespace arlight::wire {

namespace asio = boost::asio;
namespace beast = boost::beast;
namespace websocket = beast::websocket;

namespace {

// Bytes asked of the stream per read: a message grows by at most this much beyond the limit.
constexpr std::size_t kReadChunk = 64 * 1024;

template <class Ws>
void configure(Ws& ws, bool server) {
  // permessage-deflate is for browsers: they have no zstd, so their map tiles travel as raw half
  // floats that deflate compresses. Native clients never offer it: their tiles are zstd already
  // and JPEG frames do not compress (deflating a 40 KB frame costs ~4 ms at Beast's default
  // level, which on this 2-core machine cost 8 sessions most of their frames; bench/RESULTS.md).
  // The server compresses at level 3: tiles compress nearly as well, in a fraction of the time.
  websocket::permessage_deflate deflate;
  deflate.server_enable = server;
  deflate.client_enable = false;
  deflate.compLevel = 3;
  ws.set_option(deflate);
  // Opening and closing handshakes are bounded; an idle connection is the session's business.
  websocket::stream_base::timeout timeout;
  timeout.handshake_timeout = std::chrono::seconds(10);
  timeout.idle_timeout = websocket::stream_base::none();
  timeout.keep_alive_pings = false;
  ws.set_option(timeout);
  ws.read_message_max(0);  // no limit of Beast's: async_read bounds each message itself
  ws.binary(true);
  if (server)
    ws.set_option(websocket::stream_base::decorator(
        [](websocket::response_type& res) { res.set(beast::http::field::server, "arlightd"); }));
}

template <class Ws>
class WebSocketTransport final : public Transport {
 public:
  // The stream's executor must be a strand (the daemon accepts on one; the client runs one
  // thread): completion handlers run on it.
  WebSocketTransport(Ws ws, std::optional<UpgradeRequest> upgrade)
      : ws_(std::make_shared<Ws>(std::move(ws))), upgrade_(std::move(upgrade)) {
    auto& socket = beast::get_lowest_layer(*ws_).socket();
    boost::system::error_code ec;
    const auto ep = socket.remote_endpoint(ec);
    peer_ = ec ? "?" : ep.address().to_string() + ":" + std::to_string(ep.port());
    configure_socket(socket);
    if constexpr (kTls) time_tls_reads(ws_->next_layer().native_handle(), &arrival_);
  }
  // The stream may outlive the transport (a closing handshake): its reads time nothing more.
  ~WebSocketTransport() override { stop_timing(); }

  asio::any_io_executor executor() override { return ws_->get_executor(); }
  std::string peer() const override { return peer_; }
  int native_socket() override { return beast::get_lowest_layer(*ws_).socket().native_handle(); }

  void async_start(Done done) override {
    if (!upgrade_) return asio::post(ws_->get_executor(), [done = std::move(done)] { done({}); });
    configure(*ws_, /*server=*/true);
    ws_->async_accept(*upgrade_,
                      [done = std::move(done)](boost::system::error_code ec) { done(ec); });
  }

  void async_read(std::vector<std::uint8_t>& envelope, std::uint32_t max_bytes,
                  ReadDone done) override {
    envelope.clear();
    arrival_.start();
    read_more(envelope, max_bytes, std::move(done));
  }

  Arrival last_arrival() const override { return arrival_.arrival(); }

  // Bytes as one binary message: the WebSocket frames carry the length, so `framed` (a length
  // header of our own) does not apply here.
  void async_write(std::span<const std::uint8_t> bytes, bool /*framed*/, Done done) override {
    ws_->binary(true);
    ws_->async_write(
        asio::buffer(bytes.data(), bytes.size()),
        [done = std::move(done)](boost::system::error_code ec, std::size_t) { done(ec); });
  }

  // A close frame (normal closure), then the socket; bounded by the handshake timeout. The
  // stream is shared with the close operation, so it outlives this transport if need be.
  void close() override {
    if (closing_) return;
    closing_ = true;
    stop_timing();
    if (!ws_->is_open()) {
      boost::system::error_code ec;
      beast::get_lowest_layer(*ws_).socket().close(ec);
      return;
    }
    // A peer gone quiet (a link in a blackout, a client closing a stalled connection to open a
    // new one) gets a second for its closing handshake, not the opening one's ten.
    websocket::stream_base::timeout timeout;
    ws_->get_option(timeout);
    timeout.handshake_timeout = std::chrono::seconds(1);
    ws_->set_option(timeout);
    ws_->async_close(websocket::close_code::normal, [ws = ws_](boost::system::error_code) {
      boost::system::error_code ec;
      beast::get_lowest_layer(*ws).socket().close(ec);
    });
  }

 private:
  static constexpr bool kTls = std::is_same_v<Ws, SecureWebSocket>;
  void stop_timing() {
    if constexpr (kTls) time_tls_reads(ws_->next_layer().native_handle(), nullptr);
  }

  // Reads the message's payload in chunks while it stays within max_bytes (one byte over it is
  // proof enough that it is too large): nothing bigger than the limit is ever allocated.
  void read_more(std::vector<std::uint8_t>& envelope, std::uint32_t max_bytes, ReadDone done) {
    const std::size_t have = envelope.size();
    const std::size_t chunk = std::min<std::size_t>(kReadChunk, std::size_t(max_bytes) + 1 - have);
    envelope.resize(have + chunk);
    ws_->async_read_some(
        asio::buffer(envelope.data() + have, chunk),
        [this, &envelope, max_bytes, have, done = std::move(done)](boost::system::error_code ec,
                                                                   std::size_t n) mutable {
          envelope.resize(have + n);
          if (ec) return done(ec, nullptr);
          if constexpr (!kTls) arrival_.read(n);  // over TLS the reads beneath are timed
          if (ws_->got_text())
            return refuse(done, DecodeError(Fault::Malformed, "", "",
                                            "a text WebSocket message: arlight messages are "
                                            "binary, one Envelope each"));
          if (envelope.size() > max_bytes)
            return refuse(
                done, DecodeError(Fault::OverLimit, "", "",
                                  "message of more than " + std::to_string(max_bytes) +
                                      " bytes is over the limit of " + std::to_string(max_bytes)));
          if (!ws_->is_message_done()) return read_more(envelope, max_bytes, std::move(done));
          if (envelope.empty())
            return refuse(done, DecodeError(Fault::Malformed, "", "", "empty message (length 0)"));
          arrival_.stop();
          done({}, nullptr);
        });
  }

  void refuse(ReadDone& done, DecodeError error) {
    refused_ = std::move(error);
    done({}, &*refused_);
  }

  std::shared_ptr<Ws> ws_;
  std::optional<UpgradeRequest> upgrade_;
  std::optional<DecodeError> refused_;
  std::string peer_;
  bool closing_ = false;
  ArrivalTimer arrival_;
};

}  // namespace

void configure_websocket(WebSocket& ws, bool server) { configure(ws, server); }
void configure_websocket(SecureWebSocket& ws, bool server) { configure(ws, server); }

std::unique_ptr<Transport> make_websocket_transport(SecureWebSocket ws, UpgradeRequest upgrade) {
  return std::make_unique<WebSocketTransport<SecureWebSocket>>(std::move(ws), std::move(upgrade));
}
std::unique_ptr<Transport> make_websocket_transport(WebSocket ws, UpgradeRequest upgrade) {
  return std::make_unique<WebSocketTransport<WebSocket>>(std::move(ws), std::move(upgrade));
}
std::unique_ptr<Transport> make_websocket_transport(SecureWebSocket ws) {
  return std::make_unique<WebSocketTransport<SecureWebSocket>>(std::move(ws), std::nullopt);
}
std::unique_ptr<Transport> make_websocket_transport(WebSocket ws) {
  return std::make_unique<WebSocketTransport<WebSocket>>(std::move(ws), std::nullopt);
}

}  // namespace arlight::wire
