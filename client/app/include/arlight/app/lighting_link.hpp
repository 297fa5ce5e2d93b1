// The client's link to arlightd: keeps one session connected (reconnecting and resuming it
// when the server goes away), forwards frames and keeps the newest lighting it received, so
// the render loop never waits on the network: it shades with whatever lighting came last.
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <span>
#include <string>
#include <thread>
#include <vector>

#include "arlight/net/client_net.hpp"
#include "arlight/net/frame_pacer.hpp"
#include "arlight/net/unsaved_frames.hpp"

namespace arlight::client_app {

struct LinkOptions {
  std::string host;
  std::uint16_t port = 0;
  std::string device_id, token, resume_session;
  client::TlsOptions tls;
  CameraIntrinsics camera;
  std::vector<double> shininess;  // the map set to request
  int map_size = 256;
  int ggx_face = 0;  // > 0: request the room's GGX chain from this face instead (issue 34)
  // ... with up to this many small, bright lights taken out of it and shaded analytically
  // (issue 51 §1; RequestMaps::specular_lights).
  int ggx_lights = 0;
  Projection projection = Projection::AngleMap;
  // After a loss the link retries at once, then backs off (doubling from 0.1 s) to this.
  double reconnect_interval_s = 1.0;
  // The source can take a frame at a given exposure: the Hello names exposure:advice and
  // arlightd says when it needs a darker frame (take_exposure_advice()).
  bool exposure_advice = false;
  // Where and when the client is (the sun, PROTOCOL.md): sent after each handshake with a
  // server that takes it, its time moved on by the time since the link started.
  std::optional<wire::Location> location;
  // At most this many frames sent and not yet answered by a LightingUpdate (issue 36 §1): on a
  // slow link the newest frame of a live camera waits at the client instead of seconds of frames
  // in between. 0: no limit (a source that waits for its reader: every frame may go).
  int max_in_flight = 2;
};

// The newest lighting (the client core's: arlight/net/lighting_state.hpp), kept across reconnections.
using client::Lighting;

// A reconnection that resumed the session: what the server's Welcome said it had kept, and
// the coverage of the first update after it (a fail-over check: never below the checkpoint's).
struct Resume {
  std::uint64_t frames_sent_before = 0;  // this client's frames sent until then
  std::uint64_t frames_processed = 0;    // the Welcome's: what the resumed session holds
  std::uint64_t last_sequence = 0;       // the Welcome's: the newest frame it holds (this link's numbering)
  std::uint64_t frames_to_resend = 0;    // frames kept after it, sent (again) after the resume
  double first_coverage = -1;            // -1 until an update arrives
};

struct LinkStats {
  bool connected = false;
  std::string session_id;
  std::uint64_t connects = 0;  // successful handshakes (1 + reconnections)
  std::vector<Resume> resumes;
  // Frames sent (the first time), sent again after a resume (the checkpoint it resumed from
  // lacked them), kept waiting at some point (due while there was no daemon, or behind frames
  // sent again), and never sent (dropped from the kept frames' limit, or waiting at the end).
  std::uint64_t frames_sent = 0, frames_resent = 0, frames_delayed = 0, frames_not_sent = 0;
  std::uint64_t updates = 0, map_sets = 0;
  std::uint64_t exposure_advice = 0;  // ExposureAdvice messages asking for a darker frame
  std::uint64_t frames_held_back = 0;  // frames the frame advice asked not to send, or
  std::uint64_t frames_held_in_flight = 0;  // (of them) held while max_in_flight were unanswered
  // The frames' JPEGs (issue 36 §1: a narrow uplink's byte advice lowers their quality): how
  // many, their bytes and qualities summed, and the newest advice (0: none).
  std::uint64_t frames_encoded = 0, frame_bytes = 0, jpeg_quality_sum = 0;
  std::uint32_t advised_frame_bytes = 0;
  std::string last_error;
  bool refused = false;  // the server refused this client: no more attempts
};

class LightingLink {
 public:
  // Starts connecting in the background; the first attempt's failure is not fatal (the link
  // retries), but connect_now() lets a caller insist on a first connection.
  explicit LightingLink(LinkOptions options);
  ~LightingLink();  // says Bye when connected
  LightingLink(const LightingLink&) = delete;
  LightingLink& operator=(const LightingLink&) = delete;

  // Waits up to `timeout` for the first handshake; throws client::ClientError with the
  // server's reason (e.g. Unauthorized) when it was refused, or when nothing answered.
  void wait_connected(std::chrono::milliseconds timeout);

  // Whether a camera frame of width x height taken at `timestamp` (seconds) should go, how
  // reduced and at which JPEG quality: the daemon's newest frame advice (client::FramePacer). A
  // frame send_frame() sent counts from its timestamp.
  client::FramePacer::Decision frame_due(double timestamp, int width, int height);
  // Forwards a frame (`sequence` increasing) when connected and kept until a checkpoint holds
  // it; otherwise kept waiting and sent after the next handshake (the renderer goes on). After a
  // resume the frames the session lacks go again first (client::UnsavedFrames, issue 36 §5).
  // `jpeg` was encoded at `quality`.
  void send_frame(std::uint64_t sequence, const FrameInfo& info, int width, int height,
                  std::span<const std::uint8_t> jpeg, int quality);

  // At the end of a capture: waits up to `timeout` for the kept frames still waiting (an outage
  // near the end) to go; whether none waits.
  bool flush(std::chrono::duration<double> timeout);

  // Waits up to `timeout` for the first complete map set (the GGX chain when the link asks for
  // one); whether one came.
  bool wait_for_maps(std::chrono::duration<double> timeout);
  const LinkOptions& options() const { return options_; }

  Lighting lighting() const;
  LinkStats stats() const;

  // The newest exposure advice not taken yet (PROTOCOL.md, exposure advice): the exposure x
  // gain to take the next frame at, or 0 to drop an advice not used yet; nothing when no new
  // advice came since the last call.
  std::optional<double> take_exposure_advice();

 private:
  void run();
  bool connect_once();
  // With send_mutex_ held: sends kept frames waiting to go while the in-flight limit allows.
  void send_waiting(client::Client& c);
  // This link's frame numbers on the wire: a session resumed from before the link started has
  // frames up to its Welcome's last_sequence already, so the link's continue after it.
  std::uint64_t wire_sequence(std::uint64_t sequence) const { return sequence + sequence_offset_; }
  std::uint64_t link_sequence(std::uint64_t wire) const {
    return wire > sequence_offset_ ? wire - sequence_offset_ : 0;
  }

  LinkOptions options_;
  mutable std::mutex mutex_;
  std::condition_variable changed_;
  std::shared_ptr<client::Client> client_;
  Lighting lighting_;
  LinkStats stats_;
  std::optional<double> advice_;
  client::FramePacer pacer_;
  client::UnsavedFrames unsaved_;  // in this link's numbering
  std::uint64_t sequence_offset_ = 0;
  bool first_handshake_ = true;
  double newest_timestamp_ = 0;  // of the frames given: the pacer's clock
  std::mutex send_mutex_;        // one sender at a time (frames go in sequence order); before mutex_
  std::chrono::steady_clock::time_point started_ = std::chrono::steady_clock::now();
  bool refused_ = false;  // the server said no (a wrong token): retrying cannot help
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

}  // namespace arlight::client_app
