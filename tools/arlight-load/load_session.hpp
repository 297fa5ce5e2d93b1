// arlight-load's sessions: each replays a recording to arlightd at a rate for a while, as a phone
// would, and records what came back (latencies, map sets, drops, the outages it survived).
#pragma once

#include <array>
#include <chrono>
#include <cstdint>
#include <iterator>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "arlight/flags/connection_flags.hpp"
#include "arlight/net/frame_pacer.hpp"
#include "arlight/protocol/recording.hpp"

namespace arlight::load {

using Clock = std::chrono::steady_clock;

// One time a session lost its daemon and resumed (--reconnect). No frame need be lost (issue 36
// §5): the session keeps the frames no checkpoint holds yet (client::UnsavedFrames) and sends
// them again after the resume, and the frames due meanwhile wait to go after them.
struct Outage {
  double at_s = 0, seconds = 0;  // when it was noticed (since the start) and how long it lasted
  std::uint64_t delayed = 0;     // frames due while there was no daemon (sent after the resume)
  std::uint64_t to_resend = 0;   // frames the resumed session lacked (its Welcome's last_sequence)
  std::uint64_t lost = 0;        // frames dropped from the kept ones (their size limit) meanwhile
};

struct SessionReport {
  bool failed = false;
  std::string error;
  std::uint64_t sent = 0, processed = 0, dropped = 0, map_sets = 0;
  std::uint64_t map_sets_from_changes = 0;  // of them: sent as what changed (base_set)
  // Frames sent again after resumes, and frames that never reached a session (dropped from the
  // kept ones, or still waiting at the end).
  std::uint64_t resent = 0, lost = 0;
  // Frames due without a daemon that a newer one replaced before they went (a live camera's
  // newest frame wins): counted in `sent` (they had a sequence) but never sent.
  std::uint64_t replaced = 0;
  std::uint64_t held_back = 0;   // frames not sent: the daemon's frame advice asked for fewer
  std::uint64_t held_in_flight = 0;  // of them: held while max_in_flight were unanswered
  std::uint64_t bytes_sent = 0;  // of the frames' JPEGs
  // The frames' JPEG qualities summed (the advice's byte budget: a narrow uplink lowers them),
  // and the newest budget (LightingUpdate.advised_frame_bytes; 0: none).
  std::uint64_t quality_sum = 0;
  std::uint32_t advised_frame_bytes = 0;
  // What the daemon sent (client::Client::bytes_received, every connection): during the
  // recording's first pass (the room being captured, `first_pass_s` long) and after it (the
  // same frames again: a settled map).
  std::uint64_t bytes_received_first_pass = 0, bytes_received_after = 0;
  double first_pass_s = 0;
  std::vector<double> latency_ms;
  std::vector<double> map_set_ms;  // from the first frame to each completed map set
  // Per frame (index = sequence - 1): when it was sent (ms since the run started) and its
  // latency (NaN: no update reflects it, i.e. it was dropped or never answered).
  std::vector<double> sent_ms, frame_latency_ms;
  std::vector<Outage> outages;
  // Its watchers (--watchers): frame sent by the session -> the same LightingUpdate at a
  // watcher, and what they got (summed over them); watchers that failed (refused, dropped).
  std::vector<double> watcher_latency_ms;
  std::uint64_t watcher_updates = 0, watcher_map_sets = 0, watchers_failed = 0;
};

// What to send: where, as whom, how fast, for how long, from which frame and phase.
struct SessionPlan {
  std::string host, device, token;
  std::uint16_t port = 0;
  double rate = 30, duration = 10;
  bool maps = false;
  int ggx_face = 0;  // > 0: request the GGX chain from this face instead of the thesis's maps
  double phase = 0;
  std::size_t first_frame = 0;
  tools::ConnectionFlags connection;  // TLS, WebSocket
  // How long a session may be without its daemon before it counts as failed (0: any loss
  // fails it); while it is, it reconnects (at once, then every 100 ms) and resumes.
  double reconnect_s = 0;
  // Follow the LightingUpdates' frame advice (PROTOCOL.md): send the smaller JPEG it asks for and
  // hold frames back to its rate. false: every frame at the recording's size (a raw flood).
  bool follow_advice = true;
  // With follow_advice: at most this many frames sent and not yet answered by a LightingUpdate
  // (client::FramePacer::limit_in_flight; 0: no limit).
  int max_in_flight = 2;
  // Devices watching each session (Hello's watch_session) with the device's own token; they
  // only receive.
  int watchers = 0;
  // Take every map set whole (a Hello without maps:deltas, as clients before issue 36 §2).
  bool whole_sets = false;
};

// The recording's JPEGs at the camera's size and, with `reduced`, also reduced by 2, 4 and 8
// where the size divides (area averaging, quality 90), as a phone following the frame advice
// would send them; made before the sessions' clocks start and shared by them. A lower JPEG
// quality (the advice's byte budget: a narrow uplink) is encoded from those the first time a
// session asks for that frame at it, as a phone encodes each frame it sends (~1 ms at 320x240).
class FrameJpegs {
 public:
  FrameJpegs(std::vector<std::vector<std::uint8_t>> full, int width, int height, bool reduced);
  // Frame `i` `reduction` times smaller each side (1: as recorded; a reduction not made: the
  // nearest larger one made) at `quality` (one of FramePacer::kQualities; kMaxQuality: the
  // recording's at reduction 1). Any thread.
  const std::vector<std::uint8_t>& at(std::size_t i, int reduction,
                                      int quality = client::FramePacer::kMaxQuality) const;
  int width() const { return width_; }
  int height() const { return height_; }
  std::size_t size() const { return by_level_[0].size(); }

 private:
  static constexpr std::size_t kQualities = std::size(client::FramePacer::kQualities);
  struct Lower {  // one frame at a lower quality, encoded once when first asked for
    std::once_flag once;
    std::vector<std::uint8_t> jpeg;
  };
  int width_, height_;
  std::array<std::vector<std::vector<std::uint8_t>>, 4> by_level_;  // 1, 2, 4, 8 times smaller
  // [level][quality index - 1][frame]
  mutable std::array<std::array<std::unique_ptr<Lower[]>, kQualities - 1>, 4> lower_;
};

// Runs one session to its end (frames due at plan.rate for plan.duration, then the last
// updates awaited); a failure is recorded in the report, not thrown. `usable` lists the
// recording's frames with a JPEG (jpegs.at(i, 1)); `start` is the run's common clock origin.
void run_session(const SessionPlan& plan, const recording::Recording& rec, const FrameJpegs& jpegs,
                 const std::vector<std::size_t>& usable, Clock::time_point start,
                 SessionReport& report);

}  // namespace arlight::load
