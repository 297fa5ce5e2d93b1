// One client connection: reads length-prefixed messages (header checked before allocating,
// every payload through the verifier), runs the handshake, hands frames to its session and
// writes what the session sends back. Reads and writes are serialised on the connection's
// strand; a bad message gets an Error naming it and the connection closes, nothing else.
// The stream is plain TCP or TLS (Asio SSL) over it; everything above the handshake is the same.
#pragma once

#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/ssl/stream.hpp>
#include <boost/asio/strand.hpp>
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <string>
#include <variant>
#include <vector>

#include "session.hpp"

namespace arlight::daemon {

class Registry;

// What a connection needs from the daemon.
struct ConnectionEnv {
  wire::WireLimits limits;
  std::size_t max_send_queue_bytes = 64u << 20;
  std::string server_version;
  // Authenticates and returns the session for a Hello (new or resumed), or an error to send.
  std::function<std::shared_ptr<Session>(const wire::Hello&, wire::ErrorCode&, std::string&)>
      open_session;
  std::function<void(const std::string&)> log;  // rate-limited by the daemon
};

using TlsStream = boost::asio::ssl::stream<boost::asio::ip::tcp::socket>;
using ClientStream = std::variant<boost::asio::ip::tcp::socket, TlsStream>;

class Connection : public std::enable_shared_from_this<Connection> {
 public:
  Connection(ClientStream stream, const ConnectionEnv& env);
  void start();
  void close();  // from any thread

 private:
  void read_header();
  void read_payload(std::uint32_t size);
  void handle(const wire::Envelope& e);
  void handle_hello(const wire::Hello& m);
  void handle_frame(const wire::CameraFrame& m);
  void fail(wire::ErrorCode code, const std::string& message);  // Error, then close
  void send(std::vector<std::uint8_t> message);                 // from any thread
  void write_next();
  boost::asio::ip::tcp::socket::lowest_layer_type& socket();
  void shutdown();

  ClientStream stream_;
  boost::asio::strand<boost::asio::any_io_executor> strand_;
  ConnectionEnv env_;
  std::string peer_;
  std::uint8_t header_[wire::kHeaderBytes];
  std::vector<std::uint8_t> payload_;
  std::shared_ptr<Session> session_;
  bool closing_ = false;
  std::deque<std::vector<std::uint8_t>> out_;
  std::size_t out_bytes_ = 0;
  bool writing_ = false;
};

}  // namespace arlight::daemon
