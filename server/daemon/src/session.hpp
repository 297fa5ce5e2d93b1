// One capturing device's session: its capture state (arlight_capture), counters, the latest map
// request and computation, and its checkpoint in the data folder. Frames arrive from the
// network threads and are processed on the worker pool, one at a time per session, newest
// first: a frame that arrives while another is still waiting replaces it (and is counted as
// dropped), so a flood never queues without bound.
#pragma once

#include <boost/asio/steady_timer.hpp>
#include <boost/asio/thread_pool.hpp>
#include <chrono>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "arlight/admin/metrics.hpp"
#include "arlight/capture/capture.hpp"
#include "arlight/capture/exposure_advice.hpp"
#include "arlight/capture/sun.hpp"
#include "arlight/protocol/wire.hpp"
#include "checkpoint.hpp"
#include "frame_queue.hpp"
#include "map_set_scheduler.hpp"
#include "frame_path_gate.hpp"
#include "map_set_stream.hpp"
#include "uplink_rate.hpp"
#include "session_lease.hpp"
#include "sun_tracker.hpp"
#include "watchers.hpp"

namespace arlight::daemon {

using Clock = std::chrono::steady_clock;

// What every session shares: where it lives on disk, its limits, the worker pool, metrics.
struct SessionEnv {
  std::filesystem::path data_dir;
  int map_size = 512;
  capture::Fill fill = capture::Fill::Estimate;
  int align_every = 4;
  int align_max_width = 160;
  int queue_depth = 2;  // frames of a session waiting to be processed; a newer one drops the oldest
  double map_interval_s = 0.09;  // the least time between the starts of a session's map sets
  std::size_t max_watchers = 32;  // watchers a session may have (Hello's watch_session)
  std::size_t max_contributors = 4;  // other devices capturing into it (Hello's join_session)
  wire::WireLimits limits;
  boost::asio::thread_pool* workers = nullptr;
  FramePathGate* frame_path = nullptr;  // told when a session's frames come and go; map sets step aside
  admin::Counter* frames_received = nullptr;
  admin::Counter* frames_processed = nullptr;
  admin::Counter* frames_dropped = nullptr;
  admin::Counter* frames_duplicate = nullptr;
  admin::Counter* frames_skipped = nullptr;
  admin::Counter* frames_unchanged = nullptr;
  admin::Counter* frames_glanced = nullptr;
  admin::Counter* map_sets = nullptr;
  admin::Gauge* watchers = nullptr;  // of every session
  admin::Counter* light_files = nullptr;
  admin::Histogram* processing_seconds = nullptr;
  admin::Histogram* update_latency_seconds = nullptr;
  admin::Histogram* map_set_seconds = nullptr;
};

// Where a session lives on disk: DATA/sessions/<id>/ (checkpoint, lease).
std::filesystem::path session_dir(const SessionEnv& env, const std::string& id);
// A device's calibrated camera response (DATA/responses/<device>.json), or sRGB when it has
// none or it cannot be read.
CameraResponse device_response(const SessionEnv& env, const std::string& device);

class Session : public std::enable_shared_from_this<Session> {
 public:
  // `lease`: this daemon's hold on DATA/sessions/<id>/ (session_lease.hpp); the session writes
  // checkpoints only while it has it.
  Session(std::string id, std::string device_id, const SessionEnv& env, SessionLease lease);
  ~Session();

  // A checkpointed session from DATA/sessions/<id>/, or nullptr when there is none;
  // InputError when it is damaged.
  static std::shared_ptr<Session> load(const std::string& id, const SessionEnv& env,
                                       SessionLease lease);

  const std::string& id() const { return id_; }
  const std::string& device_id() const { return device_id_; }

  // The camera the frames come from. The first call creates the capture state, linearising
  // with the device's calibrated curve (DATA/responses/<device>.json) or sRGB. Later calls
  // describe the same camera, or the same size with refined optics (a browser's focal length
  // from the marker's views; at most kMaxCameraChanges a session): the map so far is kept and
  // later frames use the new intrinsics. `exposure_unknown`: the client cannot report
  // exposure (Hello's exposure:unknown), so each frame's is estimated from its overlap with
  // the map (issue 16 §4). Returns why not, or empty.
  std::string set_camera(const CameraIntrinsics& camera, bool exposure_unknown = false);
  bool has_camera() const;

  // The connected client.
  struct ClientLink {
    Sink send;  // where messages go
    wire::TileCoding tile_coding = wire::TileCoding::ZstdHalf;  // what its Hello accepts
    std::function<void()> disconnect;  // closes it (the session moves to another daemon)
    // Whether it follows exposure advice (Hello's exposure:advice; each attachment starts a
    // fresh ExposureAdvisor, since what a client can reach is its own).
    bool exposure_advice = false;
    // A client that takes map sets as what changed (Hello's maps:deltas): its connection's
    // MessageStream::bulk_begun, which says which set it will hold. Empty: whole sets.
    std::function<std::optional<std::uint64_t>(std::uint32_t lane)> bulk_begun;
  };
  // Returns the attachment's number: detach(n) lets go only if no newer connection attached
  // since (a resumed session's old connection closing late must not cut off the new one).
  std::uint64_t attach(ClientLink client);
  void detach(std::uint64_t attachment);
  bool attached() const;
  Clock::time_point last_activity() const;

  // Another device watching the session (watchers.hpp): its number, or 0 when the session has
  // its limit of watchers; admitted, it gets `welcome` first. unwatch() when its connection closes; watcher_drained() when its
  // connection wrote a message (it may be owed the newest update or set).
  std::uint64_t watch(WatcherSet::Watcher watcher, const EncodedMessage& welcome);
  void unwatch(std::uint64_t watcher);
  void watcher_drained(std::uint64_t watcher) { watchers_.drained(watcher); }

  // Two phones, one room (issue 49 §1, PROTOCOL.md "Contributors"): another device capturing
  // into this session. It gets the session's map sets as a watcher does (`watcher`, after
  // `welcome`) and the LightingUpdates of its own frames through `send`; its frames are
  // registered with the map before they are merged (capture::CaptureSession::add_device). Its
  // number, or 0 when the session has env.max_contributors or its watchers are full. A device
  // that joined before (its device id) continues with the registration it had.
  struct ContributorLink {
    std::string device_id;
    Sink send;
    WatcherSet::Watcher watcher;
    bool exposure_advice = false;  // its Hello's exposure:advice (its own advice, in its units)
  };
  std::uint64_t join(ContributorLink link, const EncodedMessage& welcome);
  void leave(std::uint64_t contributor);
  // A contributor's camera (as set_camera for the session's own; its response is its device
  // id's). Returns why not, or empty.
  std::string set_contributor_camera(std::uint64_t contributor, const CameraIntrinsics& camera,
                                     bool exposure_unknown);
  bool contributor_has_camera(std::uint64_t contributor) const;
  void submit_contributed(std::uint64_t contributor, FrameJob job);
  std::size_t contributors() const;
  // Join tokens (the session's device's RequestJoinToken): what another device may join with
  // beside the session's own token. Each lasts kJoinTokenSeconds and ends when the session's
  // device leaves (its connection closes).
  static constexpr double kJoinTokenSeconds = 600.0;
  static constexpr std::size_t kMaxJoinTokens = 8;  // the newest; an older one ends
  std::string new_join_token();
  enum class JoinTokenState { Unknown, Valid, Expired };
  JoinTokenState join_token_state(const std::string& token) const;

  void submit(FrameJob job);               // newest wins
  std::string request_maps(MapRequest r);  // empty, or why the request is refused
  // Where and when the client is (a Location message): from now on every LightingUpdate says
  // where the sun is and whether the map confirms it (capture/sun.hpp).
  void set_location(const wire::Location& location);
  // Response calibration from one view at several exposures (JPEGs, exposure x gain each), on
  // the worker pool; answers with a CalibrationResult.
  void calibrate(std::vector<std::vector<std::uint8_t>> jpegs, std::vector<double> times,
                 std::string method);
  std::uint64_t frames_processed() const;
  // The newest frame sequence the session holds (Welcome.last_sequence): a resumed client sends
  // the frames after it again.
  std::uint64_t newest_sequence() const;

  // Called periodically: starts the map set of a change that came while the last set was
  // younger than the map interval, or the full set after previews once frames pause, when no
  // frame has started it.
  void on_idle(Clock::time_point now);
  // Writes DATA/sessions/<id>/ if anything changed since the last one, and only while the
  // session holds its lease.
  void checkpoint();
  // Closes the session for good on this daemon: its connection, its work, a last checkpoint,
  // then lets go of the lease so another daemon may take it over. Throws (lease kept, session
  // usable) when the checkpoint fails.
  void release();
  bool holds_lease() const;
  // Housekeeping: renews the session's lease (session_lease.hpp); false when it was lost (this
  // daemon was stopped for longer than the lease's expiry and another took the session over):
  // then abandon() it.
  bool renew_lease();
  // Closes the session here without writing it (another daemon owns it now): its connection,
  // its watchers, its work; the lease goes. False when it had gone already.
  bool abandon();
  void shutdown();  // cancels the map computation and waits for running work
  nlohmann::json summary() const;
  std::vector<std::uint8_t> envmap_png() const;  // the live map for people to look at
  // The live map's light in the files engines read (issue 34 §2): light.json's text and
  // specular.ktx2's bytes (a GGX chain of face kLightFileFace down to 16), computed from the
  // filled map on request (~0.2 s on two cores) and kept until the next frame is merged.
  // Throws admin::NotReady before the first frame.
  struct LightFiles {
    std::string light_json;
    std::vector<std::uint8_t> specular_ktx2;
  };
  static constexpr int kLightFileFace = 128;
  std::shared_ptr<const LightFiles> light_files() const;

 private:
  void process();  // on the worker pool
  // Closes the client's connection, and with `watchers` the watchers' too.
  void disconnect_all(bool watchers);
  void end_frame_turn();  // with mutex_ held: the session's turn on the worker pool is over
  // `camera`: the frame's orientation (camera -> world), where the next view is turned from.
  // `time`: the frame's timestamp (the view guide's clock).
  // `guide`: propose the next view (the session's own device; a contributor's frames do not
  // move the view guide).
  wire::LightingUpdate lighting_update(const capture::FrameResult& r, std::uint64_t seq,
                                       const glm::dquat& camera, double time, bool guide = true);
  // The update's light_error, its map and the next view (issue 48), from the capture's
  // uncertainty and a camera looking along -Z of `camera`.
  void state_uncertainty(wire::LightingUpdate& update, const glm::dquat& camera, double time,
                         bool guide);
  void process_own(FrameJob job);  // with process_mutex_ held: a frame of the session's device
  // With process_mutex_ and mutex_ held: asks the scheduler and starts the set it says (or arms
  // the timer for one the interval deferred). Every path to a map set comes through here.
  void maybe_start_maps();
  void start_map_set(bool preview);            // with mutex_ held
  void start_maps_at(Clock::time_point when);  // with mutex_ held: maybe_start_maps() then
  // With mutex_ held: a set for `request` (the client's, or the watchers'), taking the next set
  // number and its input from the capture now.
  MapSetJob map_set_job(const MapRequest& request, bool preview, bool for_watchers);
  // With mutex_ held: the GGX chain the watchers get when the client streams none (nullopt when
  // there are no watchers, or the client's own request is a chain they share).
  std::optional<MapRequest> watcher_request() const;
  static constexpr int kWatcherGgxFace = 256;
  void compute_maps_thread(std::stop_token stop, std::vector<MapSetJob> jobs);
  // To the client and the watchers; a map set's messages as bulk data of `bulk` (watchers.hpp).
  void send(const wire::Message& message, std::optional<BulkGroup> bulk = std::nullopt,
            Audience audience = Audience::Everyone);
  // With mutex_ not held: begins the client's set `id` of `lane` in client_sets_ and returns the
  // set it is sent against (0: whole), or nullopt when the client takes only whole sets.
  std::optional<std::uint32_t> begin_client_set(std::uint32_t id, std::uint32_t lane);

  // A device capturing into the session beside its own (join()); under mutex_.
  struct Contributor {
    std::string device_id;
    Sink send;
    std::uint64_t watcher = 0;  // its place among the watchers: the map sets
    int device = -1;            // in capture_, from its first CameraIntrinsics
    std::optional<CameraIntrinsics> camera;
    bool exposure_unknown = false;
    FrameQueue frames;
    std::optional<std::uint64_t> newest_sequence;
    std::uint64_t received = 0, processed = 0, dropped = 0, skipped = 0, merged = 0;
    bool registered = false;
    std::optional<capture::ExposureAdvisor> advisor;  // when it follows advice
    explicit Contributor(int depth) : frames(depth) {}
  };
  // With mutex_ held: the next frame of this turn, round robin over the session's own queue
  // (contributor 0) and the contributors', or nullopt when none waits.
  std::optional<std::pair<std::uint64_t, FrameJob>> take_frame();
  bool frames_waiting() const;  // with mutex_ held
  // With process_mutex_ held: a contributor's frame, processed; its update goes to it and the
  // watchers.
  void process_contributed(std::uint64_t contributor, FrameJob job);

  std::string id_, device_id_;
  SessionEnv env_;
  mutable std::mutex mutex_;  // everything below
  std::unique_ptr<capture::CaptureSession> capture_;
  std::optional<CameraIntrinsics> camera_;
  static constexpr int kMaxCameraChanges = 16;
  int camera_changes_ = 0;
  std::string response_name_ = "srgb";
  Sink sink_;
  std::function<void()> disconnect_;
  std::function<std::optional<std::uint64_t>(std::uint32_t)> bulk_begun_;  // ClientLink's
  // What the client holds of the sets it was sent (issue 36 §2): cleared for a new connection
  // or request, so their first set goes whole.
  MapSetDeltas client_sets_;
  std::uint64_t attachment_ = 0;  // counts attach() calls
  wire::TileCoding tile_coding_ = wire::TileCoding::ZstdHalf;
  std::optional<capture::ExposureAdvisor> advisor_;  // when the client follows advice
  std::map<std::uint64_t, Contributor> contributors_;
  std::map<std::string, Clock::time_point> join_tokens_;  // token -> when it expires
  std::uint64_t contributors_joined_ = 0;  // numbers them
  std::uint64_t take_turn_ = 0;            // take_frame()'s round robin: the last one taken
  // Contributors' devices in capture_ by device id, and the registrations a checkpoint kept for
  // devices that have not joined again yet.
  std::map<std::string, int> contributor_devices_;
  std::map<std::string, ContributorCheckpoint> saved_contributors_;
  capture::ViewGuide view_guide_;  // the next views asked for (under mutex_)
  UplinkRate uplink_;  // the attached client's frames' arrival: advised_frame_bytes
  SunTracker sun_;      // the client's place and time, and the sun checked against the map
  FrameQueue frames_;   // at most env_.queue_depth frames wait; one a turn on the worker pool
  std::uint64_t received_ = 0, processed_ = 0, dropped_ = 0, skipped_ = 0, last_sequence_ = 0;
  // Fail-over without a lost frame (issue 36 §5, PROTOCOL.md): the newest sequence received (a
  // frame at or below it is a duplicate a resumed client sent again: not counted twice), and the
  // newest every frame up to which the last checkpoint holds (LightingUpdate.saved_sequence).
  std::optional<std::uint64_t> newest_sequence_;
  std::uint64_t duplicates_ = 0, saved_sequence_ = 0;
  // With mutex_ held: every frame up to this sequence was processed, dropped or skipped.
  std::uint64_t handled_sequence() const;
  // Of the processed frames: merged into the map (what map sets and light files follow), or
  // not, agreeing with it (capture::FrameResult::unchanged).
  std::uint64_t merged_ = 0, unchanged_ = 0;
  std::uint64_t glanced_ = 0;  // of the unchanged: found so by the glance alone
  // Frame advice (issue 37 §1, PROTOCOL.md): the frame rate a session needs while its frames
  // change the map, and once the last kSettledFrames agreed with it. A light switched on then
  // shows at the next frame, within 0.1 s, and the rate goes back up.
  static constexpr float kChangingFps = 30.0f, kSettledFps = 10.0f;
  static constexpr std::uint32_t kSettledFrames = 10;
  std::uint32_t unchanged_run_ = 0;  // frames in a row that agreed with the map
  double coverage_ = 0.0;  // the capture's, as of the last frame (for summary())
  bool dirty_ = false;
  int checkpoint_generation_ = 0;
  Clock::time_point last_activity_ = Clock::now();
  std::optional<MapRequest> request_;
  std::shared_ptr<lighting::MapUpdater> previews_;  // for request_, made by its first preview
  std::shared_ptr<lighting::GgxUpdater> ggx_previews_;  // the same for a GGX chain
  std::shared_ptr<lighting::GgxUpdater> watcher_ggx_previews_;  // the watchers' chain's
  std::uint32_t map_set_ = 0;
  MapSetScheduler maps_;  // when the next set starts
  std::unique_ptr<boost::asio::steady_timer> maps_timer_;  // a set the interval deferred
  bool maps_timer_armed_ = false;
  std::jthread map_thread_;
  // Held while a frame is processed, and by all else that reads or changes capture_ (not
  // thread-safe: even its const reads refit the fill when it is due); taken before mutex_.
  mutable std::mutex process_mutex_;
  mutable std::mutex checkpoint_mutex_;  // one checkpoint at a time (periodic, Bye, idle, ...)
  // light_files() of the map after `light_files_frames_` merged frames; taken before
  // process_mutex_ and mutex_, and held while computing (one computation a session at a time).
  mutable std::mutex light_files_mutex_;
  mutable std::shared_ptr<const LightFiles> light_files_;
  mutable std::uint64_t light_files_frames_ = 0;
  // Taken inside checkpoint_mutex_, never around disk writes: the lease is renewed on a network
  // thread, which must not wait for a checkpoint.
  mutable std::mutex lease_mutex_;
  std::optional<SessionLease> lease_;    // guarded by lease_mutex_
  // The accumulator file the newest checkpoint names, while the map has not changed since
  // (a checkpoint of new frame counts alone rewrites only the manifest); checkpoint_mutex_.
  std::optional<AccumulatorFile> accumulators_written_;
  WatcherSet watchers_;  // thread-safe; its own lock is taken after mutex_ when both are
};

}  // namespace arlight::daemon
