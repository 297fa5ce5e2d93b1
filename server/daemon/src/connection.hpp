// One client connection: the handshake, then each message to its session, and what the session
// sends back. The MessageStream (protocol/) does the transport, framing, decoding and the
// write queue; everything here runs on its strand. A bad message gets an Error naming it and
// the connection closes, nothing else.
#pragma once

#include <functional>
#include <memory>
#include <string>

#include "arlight/message_stream.hpp"
#include "session.hpp"

namespace arlight::daemon {

// The exposure assumed for the frames of a client that cannot report it (1/60 s, gain 1: what
// a phone camera in a lit room locks to; any fixed value gives the same relative map).
inline constexpr double kLockedExposureSeconds = 1.0 / 60.0;

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

class Connection : public std::enable_shared_from_this<Connection> {
 public:
  Connection(std::unique_ptr<wire::Transport> transport, const ConnectionEnv& env);
  void start();
  void close();  // from any thread

 private:
  void handle(wire::Message&& m);
  void handle_hello(const wire::Hello& m);
  void handle_intrinsics(const CameraIntrinsics& k);
  void handle_calibration(wire::CalibrationSet&& set);
  void handle_frame(wire::CameraFrame&& m);
  void fail(wire::ErrorCode code, const std::string& message);  // Error, then close
  void detach();

  std::shared_ptr<wire::MessageStream> stream_;
  ConnectionEnv env_;
  std::shared_ptr<Session> session_;
  bool closing_ = false;
  bool exposure_unknown_ = false;  // the Hello said exposure:unknown
};

}  // namespace arlight::daemon
