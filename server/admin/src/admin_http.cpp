#include "arlight/admin/admin_http.hpp"

#include <openssl/crypto.h>
#include <openssl/sha.h>

#include <array>
#include <atomic>
#include <boost/asio/dispatch.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/steady_timer.hpp>
#include <boost/asio/strand.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <chrono>
#include <exception>
#include <mutex>
#include <shared_mutex>
#include <stdexcept>
#include <string_view>
#include <utility>

namespace arlight::admin {

namespace beast = boost::beast;
namespace http = beast::http;
namespace net = boost::asio;
using tcp = net::ip::tcp;

namespace {

constexpr std::size_t kHeaderLimit = 8 * 1024;   // request line + fields
constexpr std::size_t kBufferLimit = 16 * 1024;  // > kHeaderLimit, so header_limit trips first
constexpr auto kIoTimeout = std::chrono::seconds(10);
constexpr auto kAcceptRetry = std::chrono::milliseconds(100);
constexpr std::size_t kMaxSessionIdLength = 128;
constexpr const char* kServerName = "arlightd-admin";
constexpr const char* kTextType = "text/plain; charset=utf-8";
constexpr const char* kPrometheusType = "text/plain; version=0.0.4";

using Response = http::response<http::string_body>;

// The callbacks, shared by every connection. ~AdminServer detaches them under the write lock,
// so after it returns no callback runs; connections call them under the read lock.
struct HandlerState {
  std::shared_mutex mutex;
  AdminHandlers handlers;
  bool attached = true;
};

using Digest = std::array<unsigned char, SHA256_DIGEST_LENGTH>;

Digest sha256(std::string_view bytes) {
  Digest d;
  SHA256(reinterpret_cast<const unsigned char*>(bytes.data()), bytes.size(), d.data());
  return d;
}

// What a connection needs to check a request's token: the configured token's digest.
struct AccessCheck {
  std::optional<Digest> token_digest;  // nullopt: no token configured
  bool protect_all = false;
};

// The token of an "Authorization: Bearer <token>" field (scheme case-insensitive, RFC 6750
// §2.1), or nullopt for any other form.
std::optional<std::string_view> bearer_token(std::string_view field) {
  constexpr std::string_view kScheme = "bearer";
  if (field.size() <= kScheme.size() || field[kScheme.size()] != ' ') return std::nullopt;
  for (std::size_t i = 0; i < kScheme.size(); ++i) {
    const char c = field[i];
    if ((c >= 'A' && c <= 'Z' ? char(c - 'A' + 'a') : c) != kScheme[i]) return std::nullopt;
  }
  std::string_view token = field.substr(kScheme.size());
  while (!token.empty() && token.front() == ' ') token.remove_prefix(1);
  while (!token.empty() && token.back() == ' ') token.remove_suffix(1);
  if (token.empty()) return std::nullopt;
  return token;
}

Response text_response(http::status status, std::string body,
                       const char* content_type = kTextType) {
  Response res{status, 11};
  res.set(http::field::content_type, content_type);
  res.body() = std::move(body);
  return res;
}

bool is_http_parse_error(const beast::error_code& ec) {
  static const auto& category = http::make_error_code(http::error::bad_target).category();
  return ec.category() == category;
}

enum class Route { kHealthz, kMetrics, kSessions, kEnvmap, kLightJson, kSpecularKtx2, kNotFound,
                   kBadTarget };

struct Resolved {
  Route route = Route::kNotFound;
  std::string session_id;  // the session routes only; not yet validated
};

Resolved resolve(std::string_view target) {
  if (target.empty() || target.front() != '/') return {Route::kBadTarget, {}};
  const std::string_view path = target.substr(0, target.find('?'));  // queries are ignored
  if (path == "/healthz") return {Route::kHealthz, {}};
  if (path == "/metrics") return {Route::kMetrics, {}};
  if (path == "/sessions") return {Route::kSessions, {}};
  constexpr std::string_view kPrefix = "/sessions/";
  constexpr std::pair<std::string_view, Route> kFiles[] = {{"/envmap.png", Route::kEnvmap},
                                                           {"/light.json", Route::kLightJson},
                                                           {"/specular.ktx2", Route::kSpecularKtx2}};
  for (const auto& [suffix, route] : kFiles)
    if (path.size() > kPrefix.size() + suffix.size() && path.starts_with(kPrefix) &&
        path.ends_with(suffix))
      return {route, std::string(path.substr(kPrefix.size(),
                                             path.size() - kPrefix.size() - suffix.size()))};
  return {Route::kNotFound, {}};
}

// One admin HTTP connection: read a request header, answer, repeat while kept alive. Every step
// runs on the connection's strand; pending operations hold a shared_ptr to it.
class HttpConnection : public std::enable_shared_from_this<HttpConnection> {
 public:
  HttpConnection(tcp::socket&& socket, std::shared_ptr<HandlerState> handlers,
             std::shared_ptr<const AccessCheck> access,
             std::shared_ptr<const std::atomic<bool>> stopping)
      : stream_(std::move(socket)),
        buffer_(kBufferLimit),
        handlers_(std::move(handlers)),
        access_(std::move(access)),
        stopping_(std::move(stopping)) {}

  void run() {
    net::dispatch(stream_.get_executor(),
                  beast::bind_front_handler(&HttpConnection::do_read, shared_from_this()));
  }

 private:
  void do_read() {
    parser_.emplace();
    parser_->header_limit(kHeaderLimit);
    parser_->body_limit(0);  // no route takes a body
    stream_.expires_after(kIoTimeout);
    http::async_read_header(stream_, buffer_, *parser_,
                            beast::bind_front_handler(&HttpConnection::on_read, shared_from_this()));
  }

  void on_read(beast::error_code ec, std::size_t) {
    if (ec == http::error::end_of_stream) return do_close();  // closed between requests
    if (ec == http::error::header_limit) {
      return send(text_response(http::status::request_header_fields_too_large,
                                "request header larger than 8 KiB\n"),
                  /*close=*/true);
    }
    if (ec == http::error::body_limit) return send(reject_body(), /*close=*/true);
    if (ec == http::error::partial_message) return;  // the client went away mid-request
    if (ec) {
      // A malformed request is told what was wrong; a timeout or a socket error just ends the
      // connection (the stream is already closed or broken, so there is nobody to tell).
      if (is_http_parse_error(ec)) {
        send(text_response(http::status::bad_request, "bad request: " + ec.message() + "\n"),
             /*close=*/true);
      }
      return;
    }
    if (!parser_->is_done()) return send(reject_body(), /*close=*/true);  // e.g. chunked

    const auto& req = parser_->get();
    bool close = !req.keep_alive() || stopping_->load();
    Response res = handle(req, close);
    res.version(req.version());
    send(std::move(res), close);
  }

  // A request with a body: nothing here accepts one, and it is not read, so the connection
  // cannot continue.
  Response reject_body() {
    if (parser_->get().method() != http::verb::get) return method_not_allowed();
    return text_response(http::status::payload_too_large, "request bodies are not accepted\n");
  }

  static Response method_not_allowed() {
    Response res = text_response(http::status::method_not_allowed, "only GET is supported\n");
    res.set(http::field::allow, "GET");
    return res;
  }

  Response handle(const http::request<http::empty_body>& req, bool& close) {
    const Resolved r = resolve(std::string_view(req.target().data(), req.target().size()));
    switch (r.route) {
      case Route::kBadTarget:
        return text_response(http::status::bad_request,
                             "bad request: the target must be an absolute path\n");
      case Route::kNotFound:
        return text_response(http::status::not_found,
                             "not found; the admin endpoints are /healthz, /metrics, /sessions "
                             "and /sessions/<id>/{envmap.png, light.json, specular.ktx2}\n");
      default:
        break;
    }
    const bool session_route = r.route == Route::kEnvmap || r.route == Route::kLightJson ||
                               r.route == Route::kSpecularKtx2;
    const bool protected_route = r.route == Route::kSessions || session_route || access_->protect_all;
    if (protected_route) {
      if (!access_->token_digest) {
        return text_response(http::status::forbidden,
                             "forbidden: this admin server has no token configured\n");
      }
      const auto field = req.find(http::field::authorization);
      const std::optional<std::string_view> token =
          field == req.end() ? std::nullopt
                             : bearer_token(std::string_view(field->value().data(),
                                                             field->value().size()));
      const bool ok = token && CRYPTO_memcmp(sha256(*token).data(), access_->token_digest->data(),
                                             SHA256_DIGEST_LENGTH) == 0;
      if (!ok) {
        Response res = text_response(http::status::unauthorized, "unauthorized\n");
        res.set(http::field::www_authenticate,
                token ? R"(Bearer realm="arlightd-admin", error="invalid_token")"
                      : R"(Bearer realm="arlightd-admin")");
        return res;
      }
    }
    if (req.method() != http::verb::get) return method_not_allowed();
    if (session_route && !valid_session_id(r.session_id)) {
      return text_response(http::status::bad_request,
                           "bad request: a session id is 1 to 128 characters of [A-Za-z0-9-]\n");
    }

    std::shared_lock lock(handlers_->mutex);
    if (!handlers_->attached) {
      close = true;
      return text_response(http::status::service_unavailable,
                           "the admin server is shutting down\n");
    }
    const AdminHandlers& h = handlers_->handlers;
    try {
      switch (r.route) {
        case Route::kHealthz: {
          const bool ok = !h.healthy || h.healthy();
          return ok ? text_response(http::status::ok, "ok\n")
                    : text_response(http::status::service_unavailable, "unhealthy\n");
        }
        case Route::kMetrics:
          if (!h.metrics) return not_implemented("/metrics");
          return text_response(http::status::ok, h.metrics(), kPrometheusType);
        case Route::kSessions:
          if (!h.sessions_json) return not_implemented("/sessions");
          return text_response(http::status::ok, h.sessions_json(), "application/json");
        case Route::kEnvmap: {
          if (!h.envmap_png) return not_implemented("/sessions/<id>/envmap.png");
          std::optional<std::vector<std::uint8_t>> png = h.envmap_png(r.session_id);
          if (!png) {
            return text_response(http::status::not_found, "no session '" + r.session_id + "'\n");
          }
          return text_response(http::status::ok, std::string(png->begin(), png->end()),
                               "image/png");
        }
        case Route::kLightJson:
        case Route::kSpecularKtx2: {
          const bool json = r.route == Route::kLightJson;
          if (!h.light_file) return not_implemented(json ? "/sessions/<id>/light.json" : "/sessions/<id>/specular.ktx2");
          std::optional<std::string> body = h.light_file(
              r.session_id, json ? AdminHandlers::LightFile::Json : AdminHandlers::LightFile::Ktx2);
          if (!body) {
            return text_response(http::status::not_found, "no session '" + r.session_id + "'\n");
          }
          return text_response(http::status::ok, std::move(*body), json ? "application/json" : "image/ktx2");
        }
        default:
          break;
      }
    } catch (const NotReady& e) {
      return text_response(http::status::conflict, std::string(e.what()) + "\n");
    } catch (const std::exception& e) {
      return text_response(http::status::internal_server_error,
                           std::string("internal error: ") + e.what() + "\n");
    } catch (...) {
      return text_response(http::status::internal_server_error,
                           "internal error: unknown exception\n");
    }
    return text_response(http::status::internal_server_error, "internal error: no route\n");
  }

  static Response not_implemented(const char* what) {
    return text_response(http::status::not_implemented,
                         std::string(what) + " is not provided by this server\n");
  }

  void send(Response&& res, bool close) {
    res.set(http::field::server, kServerName);
    res.set(http::field::cache_control, "no-store");
    res.keep_alive(!close);
    res.prepare_payload();
    response_ = std::make_shared<Response>(std::move(res));
    stream_.expires_after(kIoTimeout);
    http::async_write(stream_, *response_,
                      beast::bind_front_handler(&HttpConnection::on_write, shared_from_this(), close));
  }

  void on_write(bool close, beast::error_code ec, std::size_t) {
    response_.reset();
    if (ec) return;  // the stream is closed or broken; dropping the last reference closes it
    if (close) return do_close();
    do_read();
  }

  void do_close() {
    beast::error_code ec;
    stream_.socket().shutdown(tcp::socket::shutdown_send, ec);
    // The socket closes when the last reference to this connection goes, right after.
  }

  beast::tcp_stream stream_;
  beast::flat_buffer buffer_;
  std::optional<http::request_parser<http::empty_body>> parser_;
  std::shared_ptr<Response> response_;
  std::shared_ptr<HandlerState> handlers_;
  std::shared_ptr<const AccessCheck> access_;
  std::shared_ptr<const std::atomic<bool>> stopping_;
};

std::string display_address(const std::string& host, std::uint16_t port) {
  const bool v6 = host.find(':') != std::string::npos && host.front() != '[';
  return (v6 ? "[" + host + "]" : host) + ":" + std::to_string(port);
}

}  // namespace

bool valid_session_id(const std::string& id) {
  if (id.empty() || id.size() > kMaxSessionIdLength) return false;
  for (char c : id) {
    const bool ok =
        (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '-';
    if (!ok) return false;
  }
  return true;
}

struct AdminServer::Impl : std::enable_shared_from_this<Impl> {
  explicit Impl(net::io_context& io_context)
      : io(io_context), acceptor(io_context), retry_timer(io_context) {}

  // Caller holds `mutex`.
  void do_accept() {
    acceptor.async_accept(net::make_strand(io),
                          beast::bind_front_handler(&Impl::on_accept, shared_from_this()));
  }

  void on_accept(beast::error_code ec, tcp::socket socket) {
    if (!ec) std::make_shared<HttpConnection>(std::move(socket), handlers, access, stopping)->run();
    std::lock_guard lock(mutex);
    if (stopped || ec == net::error::operation_aborted) return;
    if (ec) {
      // E.g. out of file descriptors: pause briefly instead of spinning on the error.
      retry_timer.expires_after(kAcceptRetry);
      retry_timer.async_wait([self = shared_from_this()](beast::error_code wait_ec) {
        std::lock_guard relock(self->mutex);
        if (!wait_ec && !self->stopped) self->do_accept();
      });
      return;
    }
    do_accept();
  }

  net::io_context& io;
  std::mutex mutex;  // guards acceptor, retry_timer, started, stopped
  tcp::acceptor acceptor;
  net::steady_timer retry_timer;
  bool started = false;
  bool stopped = false;
  std::uint16_t port = 0;
  std::shared_ptr<HandlerState> handlers = std::make_shared<HandlerState>();
  std::shared_ptr<const AccessCheck> access;
  std::shared_ptr<std::atomic<bool>> stopping = std::make_shared<std::atomic<bool>>(false);
};

AdminServer::AdminServer(net::io_context& io, const std::string& host, std::uint16_t port,
                         AdminHandlers handlers, AdminAccess access)
    : impl_(std::make_shared<Impl>(io)) {
  impl_->handlers->handlers = std::move(handlers);
  AccessCheck check;
  if (!access.token.empty()) check.token_digest = sha256(access.token);
  check.protect_all = access.protect_all;
  impl_->access = std::make_shared<const AccessCheck>(check);
  const std::string where = display_address(host, port);
  std::string h = host;
  if (h.size() >= 2 && h.front() == '[' && h.back() == ']') h = h.substr(1, h.size() - 2);

  beast::error_code ec;
  tcp::endpoint endpoint;
  const net::ip::address address = net::ip::make_address(h, ec);
  if (!ec) {
    endpoint = tcp::endpoint(address, port);
  } else {
    tcp::resolver resolver(io);
    auto results = resolver.resolve(h, std::to_string(port), ec);
    if (ec || results.empty()) {
      throw std::runtime_error("admin HTTP: cannot resolve " + where + ": " +
                               (ec ? ec.message() : std::string("no addresses")));
    }
    endpoint = results.begin()->endpoint();
  }

  auto fail = [&](const char* step) {
    throw std::runtime_error(std::string("admin HTTP: cannot ") + step + " " + where + ": " +
                             ec.message());
  };
  tcp::acceptor& acceptor = impl_->acceptor;
  if (acceptor.open(endpoint.protocol(), ec)) fail("open a socket for");
  if (acceptor.set_option(net::socket_base::reuse_address(true), ec)) fail("configure");
  if (acceptor.bind(endpoint, ec)) fail("bind");
  if (acceptor.listen(net::socket_base::max_listen_connections, ec)) fail("listen on");
  const tcp::endpoint local = acceptor.local_endpoint(ec);
  if (ec) fail("read the bound address of");
  impl_->port = local.port();
}

AdminServer::~AdminServer() {
  stop();
  std::unique_lock lock(impl_->handlers->mutex);  // waits for callbacks running now
  impl_->handlers->attached = false;
  impl_->handlers->handlers = AdminHandlers{};  // releases what the callbacks captured
}

std::uint16_t AdminServer::port() const { return impl_->port; }

void AdminServer::start() {
  std::lock_guard lock(impl_->mutex);
  if (impl_->started || impl_->stopped) return;
  impl_->started = true;
  impl_->do_accept();
}

void AdminServer::stop() {
  std::lock_guard lock(impl_->mutex);
  if (impl_->stopped) return;
  impl_->stopped = true;
  impl_->stopping->store(true);
  beast::error_code ec;
  impl_->acceptor.close(ec);
  impl_->retry_timer.cancel();
}

}  // namespace arlight::admin
