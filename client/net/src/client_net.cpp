#include "arlight/client_net.hpp"

#include <openssl/ssl.h>

#include <boost/asio/connect.hpp>
#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/post.hpp>
#include <boost/asio/read.hpp>
#include <boost/asio/ssl.hpp>
#include <boost/asio/write.hpp>
#include <cstring>
#include <deque>
#include <thread>
#include <variant>

#include "arlight/wire.hpp"

namespace arlight::client {

namespace asio = boost::asio;
using asio::ip::tcp;
using Clock = std::chrono::steady_clock;
using TlsStream = asio::ssl::stream<tcp::socket>;

// Bytes a caller may queue ahead of the network before send() waits: bounded memory, and a
// frame source faster than the link slows down instead of piling frames up.
constexpr std::size_t kMaxQueuedBytes = 16u << 20;

// All network I/O runs on one thread (`io_thread`) as asynchronous operations, so a TLS stream
// is never read and written from two threads at once; callers' sends are posted to it.
struct Client::Impl {
  asio::io_context io;
  TlsOptions tls_options;
  std::unique_ptr<asio::ssl::context> tls_context;
  std::variant<tcp::socket, TlsStream> stream{std::in_place_index<0>, io};
  std::thread io_thread;

  // Read state (io thread only).
  std::uint8_t header[wire::kHeaderBytes];
  std::vector<std::uint8_t> payload;
  wire::WireLimits limits{.max_message_bytes = 64u << 20};
  // Write state (io thread only), apart from queued_bytes (under `mutex`).
  std::deque<std::vector<std::uint8_t>> out;
  bool writing = false;

  mutable std::mutex mutex;  // state below
  std::condition_variable changed;
  bool open = false;
  std::size_t queued_bytes = 0;
  std::optional<Welcome> welcome;
  std::optional<LightingUpdate> last_update;
  std::optional<std::pair<std::string, std::string>> error;
  std::uint64_t updates = 0, completed = 0;
  std::map<std::uint32_t, MapSet> building;
  std::optional<MapSet> last_complete;
  std::optional<CalibrationResult> calibration;
  std::vector<double> requested_shininess;
  Client* owner = nullptr;

  tcp::socket::lowest_layer_type& socket() {
    return std::visit([](auto& s) -> tcp::socket::lowest_layer_type& { return s.lowest_layer(); },
                      stream);
  }

  // From any thread: queues the message for the io thread (waits while too much is queued).
  void send(std::vector<std::uint8_t> bytes) {
    {
      std::unique_lock lock(mutex);
      changed.wait(lock, [&] { return !open || queued_bytes < kMaxQueuedBytes; });
      if (!open)
        throw ClientError("Network",
                          "send failed: " + (error ? error->second : std::string("not connected")));
      queued_bytes += bytes.size();
    }
    asio::post(io, [this, b = std::move(bytes)]() mutable {
      out.push_back(std::move(b));
      if (!writing) write_next();
    });
  }

  void write_next() {
    if (out.empty()) {
      writing = false;
      return;
    }
    writing = true;
    std::visit(
        [this](auto& s) {
          asio::async_write(s, asio::buffer(out.front()),
                            [this](boost::system::error_code ec, std::size_t) {
                              {
                                std::lock_guard lock(mutex);
                                queued_bytes -= out.front().size();
                                changed.notify_all();
                              }
                              out.pop_front();
                              if (ec) {
                                out.clear();
                                writing = false;
                                return fail("Network", "send failed: " + ec.message());
                              }
                              write_next();
                            });
        },
        stream);
  }

  void fail(const std::string& code, const std::string& message) {
    std::lock_guard lock(mutex);
    if (!error) error = {code, message};
    open = false;
    changed.notify_all();
  }

  // The read loop: header, payload (length checked before allocating), verify, handle, again.
  void read_header() {
    std::visit(
        [this](auto& s) {
          asio::async_read(
              s, asio::buffer(header), [this](boost::system::error_code ec, std::size_t) {
                if (ec) return fail("Network", "connection closed: " + ec.message());
                std::string why;
                const auto size = wire::read_header(std::span<const std::uint8_t, 4>(header),
                                                    limits.max_message_bytes, why);
                if (!size) return fail("Protocol", why);
                payload.resize(*size);
                read_payload();
              });
        },
        stream);
  }

  void read_payload() {
    std::visit(
        [this](auto& s) {
          asio::async_read(s, asio::buffer(payload),
                           [this](boost::system::error_code ec, std::size_t) {
                             if (ec) return fail("Network", "connection closed: " + ec.message());
                             std::string why;
                             const wire::Envelope* e = wire::verify_envelope(payload, why);
                             if (!e) return fail("Protocol", why);
                             handle(*e);
                             read_header();
                           });
        },
        stream);
  }

  void handle(const wire::Envelope& e) {
    using M = wire::Message;
    std::function<void(const LightingUpdate&)> update_cb;
    std::function<void(const MapSet&)> maps_cb;
    std::optional<LightingUpdate> update_copy;
    std::optional<MapSet> maps_copy;
    {
      std::lock_guard lock(mutex);
      switch (e.message_type()) {
        case M::Welcome: {
          const auto* w = e.message_as_Welcome();
          welcome = Welcome{w->session_id() ? w->session_id()->str() : "",
                            w->server_version() ? w->server_version()->str() : "", w->resumed(),
                            w->frames_processed()};
          break;
        }
        case M::Error: {
          const auto* m = e.message_as_Error();
          error = {wire::EnumNameErrorCode(m->code()), m->message() ? m->message()->str() : ""};
          break;
        }
        case M::LightingUpdate: {
          const auto* m = e.message_as_LightingUpdate();
          LightingUpdate u;
          u.frame_sequence = m->frame_sequence();
          u.frame_used = m->frame_used();
          u.reason = m->reason() ? m->reason()->str() : "";
          const int order = m->sh_order();
          u.sh = ShCoeffs(order);
          if (m->sh() && m->sh()->size() == u.sh.c.size() * 3)
            for (std::size_t k = 0; k < u.sh.c.size(); ++k)
              u.sh.c[k] = glm::dvec3(m->sh()->Get(flatbuffers::uoffset_t(3 * k)),
                                     m->sh()->Get(flatbuffers::uoffset_t(3 * k + 1)),
                                     m->sh()->Get(flatbuffers::uoffset_t(3 * k + 2)));
          if (m->dominant_direction())
            u.dominant_direction = {m->dominant_direction()->x(), m->dominant_direction()->y(),
                                    m->dominant_direction()->z()};
          if (m->dominant_color())
            u.dominant_colour = {m->dominant_color()->x(), m->dominant_color()->y(),
                                 m->dominant_color()->z()};
          u.coverage = m->coverage();
          u.frames_processed = m->frames_processed();
          u.frames_dropped = m->frames_dropped();
          u.received = Clock::now();
          last_update = u;
          ++updates;
          update_cb = owner->on_update;
          update_copy = std::move(u);
          break;
        }
        case M::MapTile:
          add_tile(*e.message_as_MapTile());
          break;
        case M::MapSetComplete: {
          const auto* m = e.message_as_MapSetComplete();
          auto it = building.find(m->map_set());
          if (it != building.end()) {
            it->second.complete = true;
            it->second.server_seconds = m->seconds();
            it->second.coverage = m->coverage();
            it->second.frames = m->frames();
            last_complete = std::move(it->second);
            building.erase(building.begin(), std::next(it));  // older sets are stale
            ++completed;
            maps_cb = owner->on_map_set_complete;
            maps_copy = *last_complete;
          }
          break;
        }
        case M::CalibrationResult: {
          const auto* m = e.message_as_CalibrationResult();
          calibration = CalibrationResult{m->stored(), m->method() ? m->method()->str() : "",
                                          m->message() ? m->message()->str() : "", m->frames()};
          break;
        }
        default:
          break;  // Progress, Pong: nothing to keep
      }
      changed.notify_all();
    }
    if (update_cb && update_copy) update_cb(*update_copy);
    if (maps_cb && maps_copy) maps_cb(*maps_copy);
  }

  // With `mutex` held. Tiles are checked against the map they claim to belong to.
  void add_tile(const wire::MapTile& t) {
    if (t.map_width() == 0 || t.map_height() == 0 || t.map_width() > 8192 ||
        t.map_height() > 8192 || t.level() > 12)
      return;
    auto guess = EnvLayout::guess_projection(int(t.map_width()), int(t.map_height()));
    if (!guess) return;
    MapSet& set = building[t.map_set()];
    set.id = t.map_set();
    const std::size_t index = t.map_index();
    if (index >= 64) return;
    if (set.maps.size() <= index) {
      const EnvLayout layout(Projection(int(t.projection())), int(t.map_width()),
                             int(t.map_height()));
      while (set.maps.size() <= index) set.maps.emplace_back(layout);
      set.shininess.resize(set.maps.size(), 0.0);
      set.texels_received.resize(set.maps.size(), 0);
    }
    set.shininess[index] = t.shininess();
    if (t.level() > 0) {
      set.preview_received = true;
      return;
    }
    EnvMap& map = set.maps[index];
    const std::uint64_t x = t.x(), y = t.y(), w = t.width(), h = t.height();
    if (w == 0 || h == 0 || x + w > std::uint64_t(map.image.width()) ||
        y + h > std::uint64_t(map.image.height()) || !t.data())
      return;
    std::string why;
    const auto px = wire::decode_half_rgb(std::span(t.data()->data(), t.data()->size()),
                                          std::size_t(w * h), why);
    if (!px) return;
    for (std::uint64_t r = 0; r < h; ++r)
      std::memcpy(map.image.view().pixel(int(x), int(y + r)), px->data() + r * w * 3,
                  sizeof(float) * 3 * w);
    set.texels_received[index] += std::size_t(w * h);
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

Welcome Client::connect(const std::string& host, std::uint16_t port, const std::string& device_id,
                        const std::string& token, const std::string& client_name,
                        const std::string& resume_session, std::chrono::milliseconds timeout) {
  Impl& d = *impl_;
  if (d.io_thread.joinable()) throw ClientError("Network", "already connected");
  boost::system::error_code ec;
  tcp::resolver resolver(d.io);
  const auto endpoints = resolver.resolve(host, std::to_string(port), ec);
  if (ec) throw ClientError("Network", "cannot resolve " + host + ": " + ec.message());
  if (d.tls_context) d.stream.emplace<TlsStream>(d.io, *d.tls_context);
  const std::string where = host + ":" + std::to_string(port);
  asio::connect(d.socket(), endpoints, ec);
  if (ec) throw ClientError("Network", "cannot connect to " + where + ": " + ec.message());
  d.socket().set_option(tcp::no_delay(true), ec);
  if (auto* tls = std::get_if<TlsStream>(&d.stream)) {
    // Server name indication, and the certificate must name the host (or its IP address).
    SSL_set_tlsext_host_name(tls->native_handle(), host.c_str());
    if (d.tls_options.verify) tls->set_verify_callback(asio::ssl::host_name_verification(host));
    tls->handshake(asio::ssl::stream_base::client, ec);
    if (ec) {
      d.socket().close();
      throw ClientError("TLS", "TLS handshake with " + where + " failed: " + ec.message());
    }
  }
  {
    std::lock_guard lock(d.mutex);
    d.open = true;
  }
  d.read_header();
  d.io_thread = std::thread([&d] { d.io.run(); });
  flatbuffers::FlatBufferBuilder b(256);
  const auto caps = b.CreateVectorOfStrings({"maps", "jpeg"});
  const auto hello = wire::CreateHello(b, wire::kProtocolVersion, b.CreateString(client_name),
                                       b.CreateString(device_id), b.CreateString(token), caps,
                                       b.CreateString(resume_session));
  b.Finish(wire::CreateEnvelope(b, wire::Message::Hello, hello.Union()),
           wire::EnvelopeIdentifier());
  d.send(wire::frame_message(b));
  std::unique_lock lock(d.mutex);
  d.changed.wait_for(lock, timeout, [&] { return d.welcome || d.error || !d.open; });
  if (d.welcome) return *d.welcome;
  const auto err = d.error.value_or(std::pair<std::string, std::string>{"Network", "no Welcome"});
  lock.unlock();
  close();
  throw ClientError(err.first, err.second);
}

void Client::send_intrinsics(const CameraIntrinsics& k) {
  flatbuffers::FlatBufferBuilder b(256);
  const auto m = wire::CreateCameraIntrinsics(
      b, std::uint32_t(k.width), std::uint32_t(k.height), k.fx, k.fy, k.cx, k.cy,
      b.CreateVector(std::vector<double>(k.distortion.begin(), k.distortion.end())));
  b.Finish(wire::CreateEnvelope(b, wire::Message::CameraIntrinsics, m.Union()),
           wire::EnvelopeIdentifier());
  impl_->send(wire::frame_message(b));
}

void Client::send_jpeg_frame(std::uint64_t sequence, const capture::FrameInfo& info, int width,
                             int height, std::span<const std::uint8_t> jpeg) {
  flatbuffers::FlatBufferBuilder b(jpeg.size() + 512);
  const wire::Quat q(info.orientation.w, info.orientation.x, info.orientation.y,
                     info.orientation.z);
  const auto data = b.CreateVector(jpeg.data(), jpeg.size());
  const auto m = wire::CreateCameraFrame(b, sequence, info.timestamp, info.exposure, info.gain, &q,
                                         wire::PixelFormat::Jpeg, std::uint32_t(width),
                                         std::uint32_t(height), data);
  b.Finish(wire::CreateEnvelope(b, wire::Message::CameraFrame, m.Union()),
           wire::EnvelopeIdentifier());
  impl_->send(wire::frame_message(b));
}

void Client::request_maps(const std::vector<double>& shininess, int size, Projection projection,
                          const std::string& method) {
  flatbuffers::FlatBufferBuilder b(256);
  std::vector<float> s(shininess.begin(), shininess.end());
  const auto m = wire::CreateRequestMaps(b, b.CreateVector(s), std::uint32_t(size),
                                         wire::Projection(int(projection)), b.CreateString(method));
  b.Finish(wire::CreateEnvelope(b, wire::Message::RequestMaps, m.Union()),
           wire::EnvelopeIdentifier());
  impl_->send(wire::frame_message(b));
}

void Client::send_calibration_set(const std::string& method, int width, int height,
                                  const std::vector<CalibrationFrame>& frames) {
  flatbuffers::FlatBufferBuilder b(1024);
  std::vector<flatbuffers::Offset<wire::CameraFrame>> offsets;
  std::uint64_t seq = 0;
  for (const CalibrationFrame& f : frames) {
    const wire::Quat q(f.info.orientation.w, f.info.orientation.x, f.info.orientation.y,
                       f.info.orientation.z);
    const auto data = b.CreateVector(f.jpeg.data(), f.jpeg.size());
    offsets.push_back(wire::CreateCameraFrame(b, ++seq, f.info.timestamp, f.info.exposure,
                                              f.info.gain, &q, wire::PixelFormat::Jpeg,
                                              std::uint32_t(width), std::uint32_t(height), data));
  }
  const auto m = wire::CreateCalibrationSet(b, b.CreateString(method), b.CreateVector(offsets));
  b.Finish(wire::CreateEnvelope(b, wire::Message::CalibrationSet, m.Union()),
           wire::EnvelopeIdentifier());
  impl_->send(wire::frame_message(b));
}

void Client::ping(std::uint64_t nonce) { impl_->send(wire::make_ping(nonce)); }
void Client::bye() { impl_->send(wire::make_bye()); }
void Client::send_raw(std::span<const std::uint8_t> bytes) {
  impl_->send(std::vector<std::uint8_t>(bytes.begin(), bytes.end()));
}

void Client::close() {
  Impl& d = *impl_;
  if (d.io_thread.joinable()) {
    asio::post(d.io, [&d] {
      boost::system::error_code ec;
      d.socket().shutdown(tcp::socket::shutdown_both, ec);
      d.socket().close(ec);
    });
    d.io_thread.join();  // the pending read and writes end with the socket
  }
  boost::system::error_code ec;
  d.socket().close(ec);
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
std::optional<MapSet> Client::last_complete_maps() const {
  std::lock_guard lock(impl_->mutex);
  return impl_->last_complete;
}
std::optional<std::pair<std::string, std::string>> Client::server_error() const {
  std::lock_guard lock(impl_->mutex);
  return impl_->error;
}
std::optional<CalibrationResult> Client::calibration_result() const {
  std::lock_guard lock(impl_->mutex);
  return impl_->calibration;
}
bool Client::connected() const {
  std::lock_guard lock(impl_->mutex);
  return impl_->open;
}
std::uint64_t Client::updates_received() const {
  std::lock_guard lock(impl_->mutex);
  return impl_->updates;
}
std::uint64_t Client::map_sets_completed() const {
  std::lock_guard lock(impl_->mutex);
  return impl_->completed;
}

}  // namespace arlight::client
