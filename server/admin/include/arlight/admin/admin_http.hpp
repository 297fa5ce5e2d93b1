// arlightd's admin HTTP server (Boost.Beast, HTTP/1.1, plain TCP, meant for loopback or a
// cluster-internal address):
//
//   GET /healthz                    200 "ok\n" when healthy(), else 503 (text/plain)
//   GET /metrics                    Prometheus text (text/plain; version=0.0.4)
//   GET /sessions                   JSON array of the sessions (application/json)
//   GET /sessions/<id>/envmap.png   the session's live environment map (image/png); 404 for an
//                                   unknown session, 400 for an id outside [A-Za-z0-9-]{1,128}
//   GET /sessions/<id>/light.json   its light for other engines (application/json: SH-9 in
//   GET /sessions/<id>/specular.ktx2  WebXR/Filament/Unity shapes; the GGX chain as KTX2,
//                                   image/ktx2); common/light_files.hpp has the formats; 409
//                                   while the session has no map yet
//
// Access (AdminAccess): the routes that show a room, /sessions and /sessions/<id>/..., need
// "Authorization: Bearer <token>"; /healthz and /metrics are open (Prometheus and probes scrape
// them) unless protect_all is set. A missing or wrong token is 401 with a WWW-Authenticate
// challenge (RFC 6750) and nothing else, checked before anything about the request is looked at.
// Tokens are compared as SHA-256 digests with CRYPTO_memcmp, so neither the time nor the length
// tells an attacker how close a guess was. With no token configured the protected routes are
// 403: they are never open by accident.
//
// Any other path is 404, any method but GET on a known path 405. The content comes from
// callbacks (AdminHandlers), which run on the io_context's threads, possibly concurrently, so
// they must be thread-safe. A callback that throws gives a 500 with the exception's message;
// an empty callback gives 501 (an empty `healthy` counts as healthy).
//
// Limits per connection: request header <= 8 KiB (else 431 and close), no request body (a
// request with one is answered 405/413 and the connection closed), 10 s to receive each
// request and to send each response (else the connection is closed). Keep-alive is supported.
// Each connection is independent: a slow, malformed or hostile client only loses its own
// connection.
#pragma once

#include <boost/asio/io_context.hpp>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace arlight::admin {

// Thrown by a handler for a resource that exists but has nothing to show yet (a session that
// has received no frame): answered 409 with the message.
class NotReady : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct AdminHandlers {
  std::function<std::string()> metrics;        // Prometheus text
  std::function<std::string()> sessions_json;  // JSON array text
  // PNG bytes of a session's live environment map, std::nullopt if no such session.
  std::function<std::optional<std::vector<std::uint8_t>>(const std::string& session_id)> envmap_png;
  std::function<bool()> healthy;  // /healthz: 200 "ok\n" when true, 503 otherwise
  // A session's light file: light.json's text or specular.ktx2's bytes, std::nullopt if no
  // such session.
  enum class LightFile { Json, Ktx2 };
  std::function<std::optional<std::string>(const std::string& session_id, LightFile file)> light_file;
};

struct AdminAccess {
  std::string token;         // the bearer token; empty: protected routes are refused (403)
  bool protect_all = false;  // /healthz and /metrics need the token too
};

// True for a session id the admin routes accept: 1 to 128 characters of [A-Za-z0-9-].
bool valid_session_id(const std::string& id);

class AdminServer {
 public:
  // Binds and listens immediately; throws std::runtime_error naming host:port on failure.
  // host is an IP address ("127.0.0.1", "::1", "[::1]", "0.0.0.0") or a name to resolve
  // ("localhost"); port 0 picks an ephemeral port (see port()).
  AdminServer(boost::asio::io_context& io, const std::string& host, std::uint16_t port,
              AdminHandlers handlers, AdminAccess access = {});
  // Stops accepting and detaches the handlers: once the destructor returns, no callback is
  // running or will run again (a request still arriving on an open connection gets 503 and
  // the connection is closed). Destroy the server before its io_context.
  ~AdminServer();
  AdminServer(const AdminServer&) = delete;
  AdminServer& operator=(const AdminServer&) = delete;

  std::uint16_t port() const;  // the bound port
  void start();                // begins accepting on `io` (the caller runs io on its threads)
  void stop();  // closes the acceptor (thread-safe, idempotent); open connections finish their
                // current request and are then closed instead of kept alive

 private:
  struct Impl;
  std::shared_ptr<Impl> impl_;  // shared with pending operations, which may outlive *this
};

}  // namespace arlight::admin
