// The protocol client (protocol/PROTOCOL.md): connect to arlightd, handshake, send intrinsics
// and frames, receive lighting updates and assemble map tiles into maps, over TCP, TLS or a
// WebSocket on the web port.
// Sends queue (bounded) from the caller's thread; one background thread does all the network
// I/O: it writes the queue and reads, verifies and decodes what the server sends.
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

#include "arlight/common/build.hpp"
#include "arlight/common/camera.hpp"
#include "arlight/common/frame.hpp"
#include "arlight/common/projection.hpp"
#include "arlight/common/sh.hpp"
#include "arlight/net/client_messages.hpp"
#include "arlight/net/lighting_state.hpp"
#include "arlight/protocol/wire.hpp"

namespace arlight::client {

// The server refused something or the connection failed; `code` is the wire ErrorCode's name
// when the server sent an Error ("Unauthorized", ...), "Network" or "Protocol" otherwise.
class ClientError : public std::runtime_error {
 public:
  ClientError(std::string code, const std::string& message)
      : std::runtime_error(code + ": " + message), code_(std::move(code)) {}
  const std::string& code() const { return code_; }

 private:
  std::string code_;
};

using Welcome = wire::Welcome;

// A LightingUpdate as the client keeps it: the message and when it arrived.
struct LightingUpdate : wire::LightingUpdate {
  std::chrono::steady_clock::time_point received;
};

using CalibrationResult = wire::CalibrationResult;

// TLS to an arlightd started with --tls-cert/--tls-key.
struct TlsOptions {
  bool enabled = false;  // a ca_file turns TLS on as well
  std::string ca_file;   // PEM file of trusted certificates; empty: the system's
  bool verify = true;    // check the chain and that the certificate names the host
};

// One exposure of a calibration set.
struct CalibrationFrame {
  FrameInfo info;
  std::vector<std::uint8_t> jpeg;
};

class Client {
 public:
  Client();
  ~Client();  // closes
  Client(const Client&) = delete;
  Client& operator=(const Client&) = delete;

  // Before connect(): speak TLS. Throws ClientError "TLS" when the CA file cannot be used.
  void use_tls(const TlsOptions& options);
  // Before connect(): talk to arlightd's web port (--web) over a WebSocket at `path`, as the
  // browser client does. The web port is always TLS: use_tls says whom to trust (for instance
  // the daemon's self-signed certificate); without it, the system's certificates.
  void use_websocket(bool enabled = true, const std::string& path = "/ws");
  // Before connect(): the capabilities the Hello names (wire.hpp; default "maps", "jpeg" and
  // both tile codings, so the server picks zstd).
  void set_capabilities(std::vector<std::string> capabilities);
  void add_capability(std::string capability);  // to those
  // Before connect(): watch the live session `session_id` instead of capturing (Hello's
  // watch_session, PROTOCOL.md item 1): its updates and map sets arrive as they would for the
  // capturing client; frames, intrinsics and requests are refused.
  void watch(std::string session_id);
  // Before connect(): capture into the live session `session_id` from this device beside the
  // session's own (Hello's join_session, PROTOCOL.md "Contributors"; connect with the session's
  // token and this device's own id). Send intrinsics and frames as for a session of one's own;
  // each LightingUpdate says whether this device is registered with the session's map yet, and
  // the session's map sets arrive as a watcher's do.
  void join(std::string session_id);

  // Connects and handshakes (TCP, TLS, WebSocket, Hello and Welcome) within `timeout`; throws
  // ClientError (e.g. code "Unauthorized", "TLS", "Network" when nothing answered in time).
  // A server that answers Moved (the watched or joined session lives on another arlightd of its
  // fleet, PROTOCOL.md "A fleet") is left for the one it names, at most kMaxRedirects times;
  // connected_to() says where the connection ended up. Reconnect through `host` as before: after
  // a fail-over the session lives wherever its device resumed it.
  static constexpr int kMaxRedirects = 2;
  Welcome connect(const std::string& host, std::uint16_t port, const std::string& device_id,
                  const std::string& token, const std::string& client_name = "arlight-client-net",
                  const std::string& resume_session = {},
                  std::chrono::milliseconds timeout = std::chrono::seconds(10));

  void send_intrinsics(const CameraIntrinsics& camera);
  void send_jpeg_frame(std::uint64_t sequence, const FrameInfo& info, int width,
                       int height, std::span<const std::uint8_t> jpeg);
  void request_maps(const std::vector<double>& shininess, int size,
                    Projection projection = Projection::AngleMap,
                    const std::string& method = "auto");
  // Any request: the Phong set above, or a GGX chain (ggx_request()).
  void request_maps(const wire::RequestMaps& request);
  // One view at several exposures; the server answers with a CalibrationResult.
  void send_calibration_set(const std::string& method, int width, int height,
                            const std::vector<CalibrationFrame>& frames);
  // Where and when the client is; only to a server whose Welcome names "location".
  void send_location(const wire::Location& location);
  // The session's own device: asks for a token another device may join this session with
  // (join_token() once it came; only to a server whose Welcome names "join").
  void request_join_token();
  void ping(std::uint64_t nonce);
  void bye();
  void send_raw(std::span<const std::uint8_t> bytes);  // tests: anything at all
  void close();

  // Called on the reader thread.
  std::function<void(const LightingUpdate&)> on_update;
  std::function<void(const ReceivedMapSet&)> on_map_set_complete;
  // arlightd's exposure advice (PROTOCOL.md): take the next frame at advice.exposure.
  std::function<void(const wire::ExposureAdvice&)> on_exposure_advice;

  // Waits until pred() (evaluated under the client's lock) holds, the connection ends or the
  // timeout passes; returns pred().
  bool wait_for(const std::function<bool()>& pred, std::chrono::milliseconds timeout);

  // State, read under the lock in wait_for predicates or via these copies.
  std::optional<LightingUpdate> last_update() const;
  std::optional<ReceivedMapSet> last_complete_maps() const;  // the Phong set
  std::optional<ReceivedMapSet> last_complete_ggx() const;   // the GGX chain
  std::optional<std::pair<std::string, std::string>> server_error() const;  // code, message
  std::optional<CalibrationResult> calibration_result() const;
  std::optional<wire::JoinToken> join_token() const;
  bool connected() const;
  std::string connected_to() const;  // "HOST:PORT" of the server the last connect() reached
  std::uint64_t updates_received() const;
  std::uint64_t map_sets_completed() const;
  // What the server sent on this connection so far, in bytes (its messages and their framing).
  std::uint64_t bytes_received() const;
  // A frame waits for its answer and nothing at all has come for kStallSeconds (since it was
  // sent, or since the last message): a link in a blackout, on which TCP would back off and
  // retry for seconds to minutes; reconnect instead (issue 36 §3).
  static constexpr double kStallSeconds = kSanitizedBuild ? 4.0 : 1.5;
  bool stalled() const;

 private:
  Welcome connect_once(const std::string& host, std::uint16_t port, const std::string& device_id,
                       const std::string& token, const std::string& client_name,
                       const std::string& resume_session, std::chrono::milliseconds timeout);
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace arlight::client
