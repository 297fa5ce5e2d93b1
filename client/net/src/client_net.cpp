#include "arlight/net/client_net.hpp"

#include <openssl/ssl.h>

#include <boost/asio/connect.hpp>
#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/ssl.hpp>
#include <boost/asio/strand.hpp>
#include <boost/beast/core/tcp_stream.hpp>
#include <boost/beast/ssl.hpp>
#include <boost/beast/websocket.hpp>
#include <algorithm>
#include <cstring>
#include <functional>
#include <optional>
#include <thread>

#include "arlight/protocol/message_stream.hpp"
#include "arlight/protocol/websocket_transport.hpp"

namespace arlight::client {

namespace asio = boost::asio;
using asio::ip::tcp;
using Clock = std::chrono::steady_clock;

// Bytes a caller may queue ahead of the network before send() waits: bounded memory, and a
// frame source faster than the link slows down instead of piling frames up.
constexpr std::size_t kMaxQueuedBytes = 16u << 20;

// All network I/O runs on one thread (`io_thread`) inside the MessageStream, so a TLS stream is
// never read and written from two threads at once; callers' sends are queued to it.
struct Client::Impl {
  asio::io_context io;
  TlsOptions tls_options;
  bool websocket = false;
  std::string websocket_path = "/ws";
  std::vector<std::string> capabilities = {"maps",
                                           "jpeg",
                                           wire::kCapabilityTilesZstdPlanar,
                                           wire::kCapabilityTilesZstd,
                                           wire::kCapabilityTilesHalf,
                                           wire::kCapabilityMapDeltas};
  std::string watch_session;  // Hello.watch_session: a watcher
  std::string join_session;   // Hello.join_session: a contributor
  std::unique_ptr<asio::ssl::context> tls_context;
  std::shared_ptr<wire::MessageStream> stream;
  std::thread io_thread;
  wire::WireLimits limits{.max_message_bytes = 64u << 20};

  mutable std::mutex mutex;  // state below
  std::condition_variable changed;
  bool open = false;
  LightingState state;  // what the server's messages built (the one dispatch of them)
  std::optional<LightingUpdate> last_update;  // state's, with the time it arrived
  // stalled(): when the last message arrived, the newest frame sent, and when the oldest frame
  // no update has answered yet was sent (none: every frame is answered).
  Clock::time_point last_received = Clock::now();
  std::uint64_t newest_frame_sent = 0;
  std::optional<Clock::time_point> unanswered_since;
  // The server's Error, or why the connection failed (Network, Protocol).
  std::optional<std::pair<std::string, std::string>> error;
  std::string server;  // HOST:PORT this connection reached
  Client* owner = nullptr;

  // From any thread: queues the message (waits while too much is queued).
  void send(std::vector<std::uint8_t> envelope, bool framed = true) {
    {
      std::unique_lock lock(mutex);
      changed.wait(lock, [&] { return !open || stream->queued_bytes() < kMaxQueuedBytes; });
      if (!open)
        throw ClientError("Network",
                          "send failed: " + (error ? error->second : std::string("not connected")));
    }
    if (framed)
      stream->send(std::move(envelope));
    else
      stream->send_unframed(std::move(envelope));
  }
  void send(const wire::Message& m) { send(wire::encode(m)); }

  void fail(const std::string& code, const std::string& message) {
    std::lock_guard lock(mutex);
    if (!error) error = {code, message};
    open = false;
    changed.notify_all();
  }

  wire::MessageStream::Handlers handlers() {
    wire::MessageStream::Handlers h;
    h.on_message = [this](wire::Message&& m) { handle(std::move(m)); };
    h.on_bad_message = [this](const wire::DecodeError& e) {
      fail("Protocol", e.what());
      stream->close();
    };
    h.on_closed = [this](const std::string& why) { fail("Network", why); };
    h.on_sent = [this](std::size_t) {
      std::lock_guard lock(mutex);
      changed.notify_all();
    };
    return h;
  }

  // The state takes the message; the callbacks run after the lock is released, on copies.
  void handle(wire::Message&& message) {
    std::function<void(const LightingUpdate&)> update_cb;
    std::function<void(const ReceivedMapSet&)> maps_cb;
    std::function<void(const wire::ExposureAdvice&)> advice_cb;
    std::optional<wire::ExposureAdvice> advice_copy;
    std::optional<LightingUpdate> update_copy;
    std::optional<ReceivedMapSet> maps_copy;
    {
      std::lock_guard lock(mutex);
      last_received = Clock::now();
      switch (state.receive(std::move(message))) {
        case LightingState::Change::Error:
          error = state.error();
          break;
        case LightingState::Change::Update: {
          LightingUpdate u;
          static_cast<wire::LightingUpdate&>(u) = *state.last_update();
          u.received = Clock::now();
          if (u.frame_sequence >= newest_frame_sent) unanswered_since.reset();
          last_update = u;
          update_cb = owner->on_update;
          update_copy = std::move(u);
          break;
        }
        case LightingState::Change::MapSet:
          maps_cb = owner->on_map_set_complete;
          maps_copy = *state.newest_set();
          break;
        case LightingState::Change::ExposureAdvice:
          advice_cb = owner->on_exposure_advice;
          advice_copy = state.exposure_advice();
          break;
        default:
          break;
      }
      changed.notify_all();
    }
    if (advice_cb && advice_copy) advice_cb(*advice_copy);
    if (update_cb && update_copy) update_cb(*update_copy);
    if (maps_cb && maps_copy) maps_cb(*maps_copy);
  }
};

Client::Client() : impl_(std::make_unique<Impl>()) { impl_->owner = this; }

Client::~Client() { close(); }

void Client::use_tls(const TlsOptions& options) {
  Impl& d = *impl_;
  d.tls_options = options;
  if (!options.enabled && options.ca_file.empty()) {
    d.tls_context.reset();
    return;
  }
  d.tls_context = std::make_unique<asio::ssl::context>(asio::ssl::context::tls_client);
  d.tls_context->set_options(asio::ssl::context::default_workarounds |
                             asio::ssl::context::no_sslv2 | asio::ssl::context::no_sslv3 |
                             asio::ssl::context::no_tlsv1 | asio::ssl::context::no_tlsv1_1);
  boost::system::error_code ec;
  if (options.ca_file.empty())
    d.tls_context->set_default_verify_paths(ec);
  else
    d.tls_context->load_verify_file(options.ca_file, ec);
  if (ec)
    throw ClientError("TLS", "cannot load trusted certificates" +
                                 (options.ca_file.empty() ? "" : " from " + options.ca_file) +
                                 ": " + ec.message());
  d.tls_context->set_verify_mode(options.verify ? asio::ssl::verify_peer : asio::ssl::verify_none);
}

void Client::use_websocket(bool enabled, const std::string& path) {
  impl_->websocket = enabled;
  impl_->websocket_path = path;
}

void Client::set_capabilities(std::vector<std::string> capabilities) {
  impl_->capabilities = std::move(capabilities);
}

void Client::add_capability(std::string capability) {
  impl_->capabilities.push_back(std::move(capability));
}

void Client::watch(std::string session_id) { impl_->watch_session = std::move(session_id); }
void Client::join(std::string session_id) { impl_->join_session = std::move(session_id); }

namespace {

// Runs the asynchronous operation `start` (handed a completion that takes an error code) on `io`
// until it completes or `deadline`; past it, `cancel()` and its completion is awaited. Every step
// of connecting goes through it, so a server behind a link in a blackout (its SYNs or handshake
// dropped) fails within the caller's timeout instead of the kernel's minutes of retries.
boost::system::error_code run_until(
    asio::io_context& io, Clock::time_point deadline,
    const std::function<void(std::function<void(boost::system::error_code)>)>& start,
    const std::function<void()>& cancel) {
  std::optional<boost::system::error_code> result;
  start([&result](boost::system::error_code ec) { result = ec; });
  io.restart();
  while (!result && Clock::now() < deadline) io.run_one_until(deadline);
  if (result) return *result;
  cancel();
  while (!result) io.run_one();
  return asio::error::timed_out;
}

void close_quietly(tcp::socket& socket) {  // what cancels a pending connect or handshake
  boost::system::error_code ignored;
  socket.close(ignored);
}

// A TCP connection to one of `endpoints` by `deadline`.
boost::system::error_code connect_by(asio::io_context& io, tcp::socket& socket,
                                     const tcp::resolver::results_type& endpoints,
                                     Clock::time_point deadline) {
  return run_until(
      io, deadline,
      [&](auto done) {
        asio::async_connect(socket, endpoints, [done](auto e, const auto&) { done(e); });
      },
      [&] { close_quietly(socket); });
}

}  // namespace

Welcome Client::connect(const std::string& host, std::uint16_t port, const std::string& device_id,
                        const std::string& token, const std::string& client_name,
                        const std::string& resume_session, std::chrono::milliseconds timeout) {
  std::string to_host = host;
  std::uint16_t to_port = port;
  for (int redirects = 0;; ++redirects) {
    try {
      return connect_once(to_host, to_port, device_id, token, client_name, resume_session,
                          timeout);
    } catch (const ClientError& e) {
      std::string moved_to;
      {
        std::lock_guard lock(impl_->mutex);
        moved_to = impl_->state.moved_to();
        impl_->state.clear_error();
        impl_->error.reset();
      }
      if (e.code() != "Moved" || moved_to.empty()) throw;
      if (redirects == kMaxRedirects)
        throw ClientError("Moved", std::string(e.what()) + " (after " +
                                       std::to_string(kMaxRedirects) + " redirects already)");
      wire::parse_endpoint(moved_to, to_host, to_port);  // the codec checked it
      if (to_host.size() > 2 && to_host.front() == '[' && to_host.back() == ']')
        to_host = to_host.substr(1, to_host.size() - 2);  // [v6]:port
    }
  }
}

std::string Client::connected_to() const {
  std::lock_guard lock(impl_->mutex);
  return impl_->server;
}

Welcome Client::connect_once(const std::string& host, std::uint16_t port,
                             const std::string& device_id, const std::string& token,
                             const std::string& client_name, const std::string& resume_session,
                             std::chrono::milliseconds timeout) {
  Impl& d = *impl_;
  if (d.io_thread.joinable()) throw ClientError("Network", "already connected");
  boost::system::error_code ec;
  tcp::resolver resolver(d.io);
  const auto endpoints = resolver.resolve(host, std::to_string(port), ec);
  if (ec) throw ClientError("Network", "cannot resolve " + host + ": " + ec.message());
  const std::string where = host + ":" + std::to_string(port);
  const auto deadline = Clock::now() + timeout;
  const auto in_time = [&](const boost::system::error_code& e) {
    return e == asio::error::timed_out ? "no answer within " + std::to_string(timeout.count()) +
                                             " ms"
                                       : e.message();
  };
  std::unique_ptr<wire::Transport> transport;
  if (d.websocket) {
    namespace beast = boost::beast;
    if (!d.tls_context) use_tls({.enabled = true, .ca_file = {}, .verify = true});
    beast::ssl_stream<beast::tcp_stream> tls(asio::make_strand(d.io), *d.tls_context);
    auto& socket = beast::get_lowest_layer(tls).socket();
    ec = connect_by(d.io, socket, endpoints, deadline);
    if (ec) throw ClientError("Network", "cannot connect to " + where + ": " + in_time(ec));
    SSL_set_tlsext_host_name(tls.native_handle(), host.c_str());
    if (d.tls_options.verify) tls.set_verify_callback(asio::ssl::host_name_verification(host));
    ec = run_until(
        d.io, deadline,
        [&](auto done) { tls.async_handshake(asio::ssl::stream_base::client, done); },
        [&] { close_quietly(socket); });
    if (ec) throw ClientError("TLS", "TLS handshake with " + where + " failed: " + in_time(ec));
    wire::SecureWebSocket ws(std::move(tls));
    wire::configure_websocket(ws, /*server=*/false);
    ec = run_until(
        d.io, deadline, [&](auto done) { ws.async_handshake(where, d.websocket_path, done); },
        [&] { close_quietly(beast::get_lowest_layer(ws).socket()); });
    if (ec)
      throw ClientError("Network", "WebSocket handshake with " + where + d.websocket_path +
                                       " failed: " + in_time(ec));
    transport = wire::make_websocket_transport(std::move(ws));
  } else {
    tcp::socket socket(d.io);
    ec = connect_by(d.io, socket, endpoints, deadline);
    if (ec) throw ClientError("Network", "cannot connect to " + where + ": " + in_time(ec));
    if (d.tls_context) {
      wire::TlsSocket tls(std::move(socket), *d.tls_context);
      // Server name indication, and the certificate must name the host (or its IP address).
      SSL_set_tlsext_host_name(tls.native_handle(), host.c_str());
      if (d.tls_options.verify) tls.set_verify_callback(asio::ssl::host_name_verification(host));
      ec = run_until(
          d.io, deadline,
          [&](auto done) { tls.async_handshake(asio::ssl::stream_base::client, done); },
          [&] { close_quietly(tls.next_layer()); });
      if (ec) {
        tls.lowest_layer().close(ec);
        throw ClientError("TLS", "TLS handshake with " + where + " failed: " + in_time(ec));
      }
      transport = wire::make_tls_transport(std::move(tls), wire::TlsRole::Established);
    } else {
      transport = wire::make_tcp_transport(std::move(socket));
    }
  }
  d.stream = std::make_shared<wire::MessageStream>(std::move(transport),
                                                   wire::MessageStream::Options{d.limits, 0});
  {
    std::lock_guard lock(d.mutex);
    d.open = true;
    d.server = where;
  }
  if (!d.watch_session.empty() || !d.join_session.empty()) {
    std::lock_guard lock(d.mutex);
    d.state.expect_any_maps();  // a watcher (or contributor) takes the sets the session streams
  }
  d.stream->start(d.handlers());
  d.io.restart();  // the handshakes above may have left it stopped
  d.io_thread = std::thread([&d] { d.io.run(); });
  d.send(wire::Hello{wire::kProtocolVersion, client_name, device_id, token, d.capabilities,
                     resume_session, d.watch_session, d.join_session});
  std::unique_lock lock(d.mutex);
  d.changed.wait_until(lock, std::max(deadline, Clock::now() + std::chrono::milliseconds(100)),
                       [&] { return d.state.welcome() || d.error || !d.open; });
  if (d.state.welcome()) return *d.state.welcome();
  const auto err = d.error.value_or(std::pair<std::string, std::string>{"Network", "no Welcome"});
  lock.unlock();
  close();
  throw ClientError(err.first, err.second);
}

void Client::send_intrinsics(const CameraIntrinsics& k) {
  impl_->send(wire::CameraIntrinsicsMessage{k});
}


void Client::send_jpeg_frame(std::uint64_t sequence, const FrameInfo& info, int width, int height,
                             std::span<const std::uint8_t> jpeg) {
  impl_->send(jpeg_frame(sequence, info, width, height, jpeg));
  std::lock_guard lock(impl_->mutex);
  impl_->newest_frame_sent = std::max(impl_->newest_frame_sent, sequence);
  if (!impl_->unanswered_since) impl_->unanswered_since = Clock::now();  // a frame is answered
}

void Client::request_maps(const std::vector<double>& shininess, int size, Projection projection,
                          const std::string& method) {
  request_maps(map_request(shininess, size, projection, method));
}

void Client::request_maps(const wire::RequestMaps& request) {
  {
    std::lock_guard lock(impl_->mutex);
    impl_->state.expect_maps(request);
  }
  impl_->send(request);
}

void Client::send_calibration_set(const std::string& method, int width, int height,
                                  const std::vector<CalibrationFrame>& frames) {
  wire::CalibrationSet set{method, {}};
  std::uint64_t seq = 0;
  for (const CalibrationFrame& f : frames)
    set.frames.push_back(jpeg_frame(++seq, f.info, width, height, f.jpeg));
  impl_->send(set);
}

void Client::send_location(const wire::Location& location) { impl_->send(location); }

void Client::request_join_token() { impl_->send(wire::RequestJoinToken{}); }

std::optional<wire::JoinToken> Client::join_token() const {
  std::lock_guard lock(impl_->mutex);
  return impl_->state.join_token();
}
void Client::ping(std::uint64_t nonce) { impl_->send(wire::Ping{nonce}); }
void Client::bye() { impl_->send(wire::Bye{}); }
void Client::send_raw(std::span<const std::uint8_t> bytes) {
  impl_->send(std::vector<std::uint8_t>(bytes.begin(), bytes.end()), /*framed=*/false);
}

void Client::close() {
  Impl& d = *impl_;
  if (d.io_thread.joinable()) {
    d.stream->close();
    d.io_thread.join();  // the stream's pending read and writes end with the socket
  }
  std::lock_guard lock(d.mutex);
  d.open = false;
  d.changed.notify_all();
}

bool Client::wait_for(const std::function<bool()>& pred, std::chrono::milliseconds timeout) {
  const auto end = Clock::now() + timeout;
  for (;;) {
    if (pred()) return true;
    std::unique_lock lock(impl_->mutex);
    if (!impl_->open || Clock::now() >= end) {
      lock.unlock();
      return pred();
    }
    impl_->changed.wait_for(
        lock, std::min<std::chrono::milliseconds>(
                  std::chrono::milliseconds(50),
                  std::chrono::duration_cast<std::chrono::milliseconds>(end - Clock::now())));
  }
}

std::optional<LightingUpdate> Client::last_update() const {
  std::lock_guard lock(impl_->mutex);
  return impl_->last_update;
}
std::optional<ReceivedMapSet> Client::last_complete_maps() const {
  std::lock_guard lock(impl_->mutex);
  const auto& maps = impl_->state.lighting().maps;
  return maps ? std::optional<ReceivedMapSet>(*maps) : std::nullopt;
}
std::optional<ReceivedMapSet> Client::last_complete_ggx() const {
  std::lock_guard lock(impl_->mutex);
  const auto& ggx = impl_->state.lighting().ggx;
  return ggx ? std::optional<ReceivedMapSet>(*ggx) : std::nullopt;
}
std::optional<std::pair<std::string, std::string>> Client::server_error() const {
  std::lock_guard lock(impl_->mutex);
  return impl_->error;
}
std::optional<CalibrationResult> Client::calibration_result() const {
  std::lock_guard lock(impl_->mutex);
  return impl_->state.calibration();
}
bool Client::connected() const {
  std::lock_guard lock(impl_->mutex);
  return impl_->open;
}
std::uint64_t Client::updates_received() const {
  std::lock_guard lock(impl_->mutex);
  return impl_->state.updates();
}
std::uint64_t Client::map_sets_completed() const {
  std::lock_guard lock(impl_->mutex);
  return impl_->state.map_sets();
}

bool Client::stalled() const {
  std::lock_guard lock(impl_->mutex);
  if (!impl_->unanswered_since) return false;
  const Clock::time_point quiet_since = std::max(impl_->last_received, *impl_->unanswered_since);
  return std::chrono::duration<double>(Clock::now() - quiet_since).count() > kStallSeconds;
}

std::uint64_t Client::bytes_received() const {
  std::lock_guard lock(impl_->mutex);
  return impl_->stream ? impl_->stream->bytes_received() : 0;
}

}  // namespace arlight::client
