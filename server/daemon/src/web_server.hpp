// arlightd's web port (Boost.Beast, HTTPS only: browsers give camera and motion sensors to
// secure pages alone): the browser client's static files, and the WebSocket endpoint /ws whose
// connections become MessageStream transports, handed to the daemon like its TCP connections.
#pragma once

#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/ssl/context.hpp>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <string>

#include "arlight/protocol/message_stream.hpp"

namespace arlight::daemon {

struct WebServerOptions {
  std::string host = "127.0.0.1";
  std::uint16_t port = 8443;   // 0: ephemeral (tests)
  std::filesystem::path root;  // the browser client's files (index.html, its JS and WASM)
  // Each accepted /ws connection, TLS and upgrade request read (the upgrade is answered when
  // the transport starts).
  std::function<void(std::unique_ptr<wire::Transport>)> on_websocket;
  std::function<void(const std::string&)> log;  // rate-limited by the daemon
  // Each accepted connection's admission by its peer's IP address: a slot the
  // connection holds while it lasts (so plain HTTPS connections count against the daemon's
  // connection limits, issue 36), or nullptr to close it at once, before its TLS handshake.
  // Unset: every connection is admitted.
  std::function<std::shared_ptr<void>(const std::string& address)> admit;
};

// The response to a GET or HEAD of `target` (its path; a query is ignored) from `root`: the
// file's path, or why not. Only files under root, named with [A-Za-z0-9._-] segments that do
// not start with '.', are served; "/" is index.html.
struct StaticFile {
  std::optional<std::filesystem::path> path;
  int status = 200;  // 404 when path is empty
};
StaticFile resolve_static_file(const std::filesystem::path& root, std::string_view target);
// The Content-Type for a file name (application/wasm for .wasm: browsers compile it streaming
// only with that type); application/octet-stream when unknown.
const char* content_type(const std::filesystem::path& file);
// The Content-Security-Policy a file is served with: the page's (its own scripts and WebAssembly,
// no eval, only its own origin; an HTML file's inline import maps by their SHA-256), or for the
// tracking worker's script, which runs opencv.js, the same with eval allowed.
std::string content_security_policy(const std::filesystem::path& file);

class WebServer {
 public:
  // Binds (std::runtime_error naming the address when it cannot). `tls` must outlive the server.
  WebServer(boost::asio::io_context& io, boost::asio::ssl::context& tls, WebServerOptions options);
  ~WebServer();
  WebServer(const WebServer&) = delete;
  WebServer& operator=(const WebServer&) = delete;

  void start();
  void stop();  // stops accepting; connections already made end on their own
  std::uint16_t port() const;

  struct Impl;  // opaque; public so the connections in web_server.cpp can hold it

 private:
  std::shared_ptr<Impl> impl_;
};

}  // namespace arlight::daemon
