#include "web_server.hpp"

#include <boost/asio/steady_timer.hpp>
#include <boost/asio/strand.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/ssl.hpp>
#include <boost/beast/websocket.hpp>
#include <openssl/evp.h>

#include <chrono>
#include <fstream>
#include <iterator>

#include "arlight/protocol/websocket_transport.hpp"
#include "phone_link.hpp"

namespace arlight::daemon {

namespace asio = boost::asio;
namespace beast = boost::beast;
namespace http = beast::http;
namespace fs = std::filesystem;
using tcp = asio::ip::tcp;

namespace {

constexpr std::size_t kHeaderLimit = 8 * 1024;  // request line + fields
constexpr std::size_t kBodyLimit = 1024;        // GET, HEAD and upgrades carry no body
constexpr auto kHandshakeTimeout = std::chrono::seconds(10);
constexpr auto kRequestTimeout = std::chrono::seconds(30);  // between keep-alive requests
constexpr auto kAcceptRetry = std::chrono::milliseconds(100);
constexpr const char* kServerName = "arlightd";
// The page loads only its own scripts and WebAssembly and talks only to its own origin, and to
// the WebSocket of another arlightd of its fleet when this one answers Moved (issue 49 §2:
// their addresses are in the shared leases, not known here ahead, hence any wss: endpoint).
constexpr const char* kContentSecurityPolicy =
    "default-src 'self'; script-src 'self' 'wasm-unsafe-eval'; worker-src 'self' blob:; "
    "connect-src 'self' wss:; img-src 'self' data: blob:; media-src 'self' blob: mediastream:; "
    "style-src 'self' 'unsafe-inline'; frame-ancestors 'none'";
// The tracking worker's own policy (a worker runs under the one its script came with): opencv.js's
// bindings build functions from strings (embind without DYNAMIC_EXECUTION=0), so it alone may
// eval. It has no DOM and reaches only this origin.
constexpr const char* kEvalWorkerPolicy =
    "default-src 'self'; script-src 'self' 'wasm-unsafe-eval' 'unsafe-eval'; connect-src 'self'";
constexpr const char* kEvalWorkerScript = "marker_worker.js";

using Stream = beast::ssl_stream<beast::tcp_stream>;

template <class Body>
void set_common_headers(http::response<Body>& res) {
  res.set(http::field::server, kServerName);
  res.set(http::field::cache_control, "no-cache");
  res.set("X-Content-Type-Options", "nosniff");
  res.set("Referrer-Policy", "no-referrer");
  res.set("Content-Security-Policy", kContentSecurityPolicy);
}

bool allowed_segment(std::string_view s) {
  if (s.empty() || s.front() == '.') return false;
  return std::all_of(s.begin(), s.end(), [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '.' ||
           c == '_' || c == '-';
  });
}

}  // namespace

namespace {

// The SHA-256 of each `<script type="importmap">` of an HTML file, as CSP source expressions
// ('sha256-<base64>'): an import map must be inline (browsers do not load one from a file), and
// the page's policy allows exactly those (the three.js page maps `three` to its files).
std::string import_map_hashes(const fs::path& html) {
  std::ifstream in(html, std::ios::binary);
  const std::string text((std::istreambuf_iterator<char>(in)), {});
  static constexpr std::string_view kOpen = "<script type=\"importmap\">", kClose = "</script>";
  std::string sources;
  for (std::size_t at = text.find(kOpen); at != std::string::npos; at = text.find(kOpen, at)) {
    at += kOpen.size();
    const std::size_t end = text.find(kClose, at);
    if (end == std::string::npos) break;
    unsigned char digest[EVP_MAX_MD_SIZE];
    unsigned int length = 0;
    EVP_Digest(text.data() + at, end - at, digest, &length, EVP_sha256(), nullptr);
    std::string base64(4 * ((length + 2) / 3) + 1, '\0');
    base64.resize(std::size_t(EVP_EncodeBlock(reinterpret_cast<unsigned char*>(base64.data()),
                                              digest, int(length))));
    sources += " 'sha256-" + base64 + "'";
  }
  return sources;
}

}  // namespace

std::string content_security_policy(const fs::path& file) {
  if (file.filename() == kEvalWorkerScript) return kEvalWorkerPolicy;
  if (file.extension() != ".html") return kContentSecurityPolicy;
  const std::string hashes = import_map_hashes(file);
  if (hashes.empty()) return kContentSecurityPolicy;
  std::string policy = kContentSecurityPolicy;
  const std::string_view script_src = "script-src 'self'";
  policy.insert(policy.find(script_src) + script_src.size(), hashes);
  return policy;
}

StaticFile resolve_static_file(const fs::path& root, std::string_view target) {
  std::string_view path = target.substr(0, target.find_first_of("?#"));
  if (path.empty() || path.front() != '/') return {std::nullopt, 400};
  if (path == "/") path = "/index.html";
  fs::path file = root;
  for (std::size_t start = 1; start <= path.size();) {
    const std::size_t end = std::min(path.find('/', start), path.size());
    const std::string_view segment = path.substr(start, end - start);
    if (!allowed_segment(segment)) return {std::nullopt, 404};
    file /= std::string(segment);
    start = end + 1;
  }
  std::error_code ec;
  if (!fs::is_regular_file(file, ec)) return {std::nullopt, 404};
  return {file, 200};
}

const char* content_type(const fs::path& file) {
  static const std::pair<const char*, const char*> kTypes[] = {
      {".html", "text/html; charset=utf-8"},
      {".js", "text/javascript; charset=utf-8"},
      {".mjs", "text/javascript; charset=utf-8"},
      {".css", "text/css; charset=utf-8"},
      {".json", "application/json"},
      {".wasm", "application/wasm"},
      {".data", "application/octet-stream"},
      {".png", "image/png"},
      {".jpg", "image/jpeg"},
      {".svg", "image/svg+xml"},
      {".webp", "image/webp"},
      {".ico", "image/x-icon"},
      {".glb", "model/gltf-binary"},
      {".txt", "text/plain; charset=utf-8"},
  };
  const std::string ext = file.extension().string();
  for (const auto& [e, type] : kTypes)
    if (ext == e) return type;
  return "application/octet-stream";
}

struct WebServer::Impl : std::enable_shared_from_this<WebServer::Impl> {
  asio::io_context& io;
  asio::ssl::context& tls;
  WebServerOptions options;
  tcp::acceptor acceptor;
  asio::steady_timer retry;
  std::uint16_t bound_port = 0;

  Impl(asio::io_context& io_, asio::ssl::context& tls_, WebServerOptions o)
      : io(io_), tls(tls_), options(std::move(o)), acceptor(io_), retry(io_) {}

  void accept();
};

namespace {

// One HTTPS connection: TLS, then requests until it closes or asks for a WebSocket on /ws.
class HttpSession : public std::enable_shared_from_this<HttpSession> {
 public:
  HttpSession(tcp::socket socket, std::shared_ptr<WebServer::Impl> server,
              std::shared_ptr<void> slot)
      : stream_(std::move(socket), server->tls), server_(std::move(server)),
        slot_(std::move(slot)) {}

  void start() {
    beast::get_lowest_layer(stream_).expires_after(kHandshakeTimeout);
    stream_.async_handshake(asio::ssl::stream_base::server,
                            [self = shared_from_this()](beast::error_code ec) {
                              if (ec) return self->close();  // not TLS, or a phone refusing
                              self->read_request();
                            });
  }

 private:
  void read_request() {
    parser_.emplace();
    parser_->header_limit(kHeaderLimit);
    parser_->body_limit(kBodyLimit);
    beast::get_lowest_layer(stream_).expires_after(kRequestTimeout);
    http::async_read(
        stream_, buffer_, *parser_,
        [self = shared_from_this()](beast::error_code ec, std::size_t) { self->on_request(ec); });
  }

  void on_request(beast::error_code ec) {
    if (ec == http::error::end_of_stream) return shutdown();
    if (ec) {
      if (ec.category() == http::make_error_code(http::error::bad_target).category())
        return respond_text(http::status::bad_request, "bad request: " + ec.message() + "\n",
                            false);
      return close();
    }
    http::request<http::string_body> req = parser_->release();
    if (beast::websocket::is_upgrade(req)) {
      const std::string_view target(req.target().data(), req.target().size());
      if (target.substr(0, target.find('?')) != "/ws")
        return respond_text(http::status::not_found, "WebSocket only on /ws\n", false);
      // The WebSocket stream has timeouts of its own; the session has its idle timeout.
      beast::get_lowest_layer(stream_).expires_never();
      slot_.reset();  // the daemon counts it as its own connection from here on
      wire::SecureWebSocket ws(std::move(stream_));
      if (server_->options.on_websocket)
        server_->options.on_websocket(
            wire::make_websocket_transport(std::move(ws), std::move(req)));
      return;
    }
    const bool keep_alive = req.keep_alive();
    if (req.method() != http::verb::get && req.method() != http::verb::head) {
      http::response<http::string_body> res{http::status::method_not_allowed, 11};
      res.set(http::field::allow, "GET, HEAD");
      return send_text(std::move(res), "only GET and HEAD\n", keep_alive);
    }
    const std::string_view target(req.target().data(), req.target().size());
    if (target.substr(0, target.find('?')) == "/qr.svg") return respond_qr(req, target, keep_alive);
    const StaticFile file = resolve_static_file(server_->options.root, target);
    if (!file.path) {
      const bool no_client = !fs::exists(server_->options.root / "index.html");
      return respond_text(http::status(file.status),
                          no_client ? "arlightd: the browser client is not installed in " +
                                          server_->options.root.string() +
                                          " (build it with `make web`, or give --web-root)\n"
                                    : "not found\n",
                          keep_alive);
    }
    http::file_body::value_type body;
    beast::error_code open_ec;
    body.open(file.path->c_str(), beast::file_mode::scan, open_ec);
    if (open_ec) return respond_text(http::status::not_found, "not found\n", keep_alive);
    const auto size = body.size();
    const auto headers = [&](auto& res) {
      set_common_headers(res);
      res.set("Content-Security-Policy", content_security_policy(*file.path));
      res.set(http::field::content_type, content_type(*file.path));
      res.content_length(size);
      res.keep_alive(keep_alive);
    };
    if (req.method() == http::verb::head) {  // the GET's headers, no body
      auto res = std::make_shared<http::response<http::empty_body>>(http::status::ok, 11);
      headers(*res);
      return write(res, keep_alive);
    }
    auto res = std::make_shared<http::response<http::file_body>>(
        std::piecewise_construct, std::make_tuple(std::move(body)),
        std::make_tuple(http::status::ok, 11));
    headers(*res);
    write(res, keep_alive);
  }

  // The phone page's "watch this room" QR code (issue 35): /qr.svg?three=FRAGMENT, the link to
  // /three.html#FRAGMENT on the host the page reached, and its "capture with another phone"
  // code (issue 49): /qr.svg?join=FRAGMENT, the link to /#FRAGMENT (phone_link.hpp, watch_link).
  void respond_qr(const http::request<http::string_body>& req, std::string_view target,
                  bool keep_alive) {
    const std::size_t question = target.find('?');
    const std::string link =
        question == std::string_view::npos
            ? std::string()
            : watch_link(std::string_view(req[http::field::host].data(), req[http::field::host].size()),
                         target.substr(question + 1));
    if (link.empty())
      return respond_text(http::status::bad_request,
                          "qr.svg: ?three=FRAGMENT of a /three.html link or ?join=FRAGMENT of the "
                          "page's join link (at most 512 URL-safe characters) and a plain Host\n",
                          keep_alive);
    http::response<http::string_body> res{http::status::ok, 11};
    set_common_headers(res);
    res.set(http::field::content_type, "image/svg+xml");
    res.body() = req.method() == http::verb::head ? std::string() : qr_svg(qr_modules(link));
    res.prepare_payload();
    res.keep_alive(keep_alive);
    write(std::make_shared<http::response<http::string_body>>(std::move(res)), keep_alive);
  }

  void respond_text(http::status status, std::string body, bool keep_alive) {
    send_text(http::response<http::string_body>{status, 11}, std::move(body), keep_alive);
  }

  void send_text(http::response<http::string_body> res, std::string body, bool keep_alive) {
    auto r = std::make_shared<http::response<http::string_body>>(std::move(res));
    set_common_headers(*r);
    r->set(http::field::content_type, "text/plain; charset=utf-8");
    r->body() = std::move(body);
    r->keep_alive(keep_alive);
    r->prepare_payload();
    write(r, keep_alive);
  }

  template <class Response>
  void write(std::shared_ptr<Response> res, bool keep_alive) {
    http::async_write(
        stream_, *res,
        [self = shared_from_this(), res, keep_alive](beast::error_code ec, std::size_t) {
          self->after_write(ec, keep_alive);
        });
  }

  void after_write(beast::error_code ec, bool keep_alive) {
    if (ec) return close();
    if (!keep_alive) return shutdown();
    read_request();
  }

  void shutdown() {
    beast::get_lowest_layer(stream_).expires_after(kHandshakeTimeout);
    stream_.async_shutdown([self = shared_from_this()](beast::error_code) { self->close(); });
  }

  void close() {
    beast::error_code ec;
    beast::get_lowest_layer(stream_).socket().close(ec);
  }

  Stream stream_;
  std::shared_ptr<WebServer::Impl> server_;
  beast::flat_buffer buffer_;
  std::optional<http::request_parser<http::string_body>> parser_;
  std::shared_ptr<void> slot_;  // its place under the daemon's connection limits
};

}  // namespace

void WebServer::Impl::accept() {
  acceptor.async_accept(asio::make_strand(io),
                        [self = shared_from_this()](beast::error_code ec, tcp::socket socket) {
                          if (!self->acceptor.is_open()) return;
                          if (ec) {
                            // Out of file descriptors and the like: try again shortly rather than
                            // spin.
                            if (self->options.log)
                              self->options.log("web port: accept failed: " + ec.message());
                            self->retry.expires_after(kAcceptRetry);
                            self->retry.async_wait([self](beast::error_code e) {
                              if (!e) self->accept();
                            });
                            return;
                          }
                          std::shared_ptr<void> slot;
                          if (self->options.admit) {
                            beast::error_code peer_ec;
                            const auto peer = socket.remote_endpoint(peer_ec);
                            slot = self->options.admit(peer_ec ? std::string("?")
                                                               : peer.address().to_string());
                            if (!slot) {  // over a limit: closed before anything is read
                              socket.close(peer_ec);
                              self->accept();
                              return;
                            }
                          }
                          std::make_shared<HttpSession>(std::move(socket), self, std::move(slot))
                              ->start();
                          self->accept();
                        });
}

WebServer::WebServer(asio::io_context& io, asio::ssl::context& tls, WebServerOptions options)
    : impl_(std::make_shared<Impl>(io, tls, std::move(options))) {
  Impl& d = *impl_;
  beast::error_code ec;
  const auto address = asio::ip::make_address(d.options.host, ec);
  if (ec) throw std::runtime_error("web port: '" + d.options.host + "' is not an IP address");
  const tcp::endpoint ep(address, d.options.port);
  d.acceptor.open(ep.protocol());
  d.acceptor.set_option(tcp::acceptor::reuse_address(true));
  d.acceptor.bind(ep, ec);
  if (ec)
    throw std::runtime_error("cannot serve the web page on " + d.options.host + ":" +
                             std::to_string(d.options.port) + ": " + ec.message());
  d.acceptor.listen();
  d.bound_port = d.acceptor.local_endpoint().port();
}

WebServer::~WebServer() = default;

void WebServer::start() { impl_->accept(); }

void WebServer::stop() {
  asio::post(impl_->io, [d = impl_] {
    beast::error_code ec;
    d->acceptor.close(ec);
    d->retry.cancel();
  });
}

std::uint16_t WebServer::port() const { return impl_->bound_port; }

}  // namespace arlight::daemon
