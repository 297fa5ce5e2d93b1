// One client connection: the handshake, then each message to its session, and what the session
// sends back. The MessageStream (protocol/) does the transport, framing, decoding and the
// write queue; everything here runs on its strand. A bad message gets an Error naming it and
// the connection closes, nothing else.
#pragma once

#include <atomic>
#include <boost/asio/steady_timer.hpp>
#include <chrono>
#include <functional>
#include <memory>
#include <string>

#include "arlight/admin/metrics.hpp"
#include "arlight/protocol/message_stream.hpp"
#include "session.hpp"

namespace arlight::daemon {

// What a connection needs from the daemon.
struct ConnectionEnv {
  wire::WireLimits limits;
  std::size_t max_send_queue_bytes = 64u << 20;
  std::string server_version;
  // Authenticates and returns the session for a Hello (new, resumed, or the one its
  // watch_session or join_session names), or an error to send (code, message, and for Moved
  // the address of the daemon that has the session; `web`: for a connection of the web port).
  std::function<std::shared_ptr<Session>(const wire::Hello&, bool web, wire::ErrorCode&,
                                         std::string&, std::string&)>
      open_session;
  bool web = false;  // this connection came to the web port (a WebSocket)
  std::function<void(const std::string&)> log;  // rate-limited by the daemon
  // Checkpoints a session on the daemon's disk thread (at Bye): a network thread never waits
  // for a write and its fsync.
  std::function<void(std::shared_ptr<Session>)> checkpoint_soon;
  // A connection must send its Hello within hello_timeout; an authenticated one that sends
  // nothing for idle_timeout is closed (Error{Timeout}; its session stays for a resume).
  std::chrono::duration<double> hello_timeout{5.0}, idle_timeout{300.0};
  admin::Counter* hello_timeouts = nullptr;
  admin::Counter* idle_timeouts = nullptr;
  admin::Counter* watchers_refused = nullptr;  // a session had its limit of watchers
};

// "address" of an "address:port" peer ("[v6]:port" keeps the brackets).
std::string peer_address(const std::string& peer);

// One protocol client's connection (a phone's page over /ws, arlight-client, arlight-load): its
// Hello and session, the messages it sends, the deadlines. (The admin port's connections are
// arlight_admin's HttpConnection.)
class ClientConnection : public std::enable_shared_from_this<ClientConnection> {
 public:
  ClientConnection(std::unique_ptr<wire::Transport> transport, const ConnectionEnv& env);
  void start();
  void close();  // from any thread
  // From any thread: where it comes from, and whether its Hello was accepted.
  const std::string& address() const { return address_; }
  bool authenticated() const { return authenticated_.load(); }

 private:
  void handle(wire::Message&& m);
  void handle_hello(const wire::Hello& m);
  void watch(const wire::Hello& m);  // after handle_hello found the session
  void join(const wire::Hello& m);   // the same for a contributor (Hello's join_session)
  wire::Welcome welcome(bool resumed) const;  // the session's, to this connection
  void handle_intrinsics(const CameraIntrinsics& k);
  void handle_calibration(wire::CalibrationSet&& set);
  void handle_frame(wire::CameraFrame&& m);
  // Error, then close (`address`: a Moved error's).
  void fail(wire::ErrorCode code, const std::string& message, const std::string& address = {});
  void detach();
  // The Hello deadline, then the idle deadline, on the stream's strand.
  void arm_deadline(std::chrono::steady_clock::duration after);
  void deadline_passed();

  std::shared_ptr<wire::MessageStream> stream_;
  ConnectionEnv env_;
  std::shared_ptr<Session> session_;
  std::uint64_t attachment_ = 0;  // Session::attach's number for this connection
  // A watcher (Hello's watch_session): Session::watch's number, 0 until it is admitted.
  bool watching_ = false;
  std::uint64_t watcher_ = 0;
  // A contributor (Hello's join_session): Session::join's number, 0 until it is admitted.
  bool contributing_ = false;
  std::uint64_t contributor_ = 0;
  std::string address_;
  std::atomic<bool> authenticated_{false};
  boost::asio::steady_timer deadline_;
  std::chrono::steady_clock::time_point last_message_ = std::chrono::steady_clock::now();
  bool closing_ = false;
  bool exposure_unknown_ = false;  // the Hello said exposure:unknown
};

}  // namespace arlight::daemon
