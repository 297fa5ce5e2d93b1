// One capturing device's session: its capture state (arlight_capture), counters, the latest map
// request and computation, and its checkpoint in the data folder. Frames arrive from the
// network threads and are processed on the worker pool, one at a time per session, newest
// first: a frame that arrives while another is still waiting replaces it (and is counted as
// dropped), so a flood never queues without bound.
#pragma once

#include <boost/asio/thread_pool.hpp>
#include <chrono>
#include <cstdint>
#include <deque>
#include <filesystem>
#include <functional>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "arlight/capture.hpp"
#include "arlight/metrics.hpp"
#include "arlight/wire.hpp"
#include "checkpoint.hpp"

namespace arlight::daemon {

using Clock = std::chrono::steady_clock;

// What every session shares: where it lives on disk, its limits, the worker pool, metrics.
struct SessionEnv {
  std::filesystem::path data_dir;
  int map_size = 512;
  int align_every = 4;
  int align_max_width = 160;
  int queue_depth = 2;  // frames of a session waiting to be processed; a newer one drops the oldest
  wire::WireLimits limits;
  boost::asio::thread_pool* workers = nullptr;
  admin::Counter* frames_received = nullptr;
  admin::Counter* frames_processed = nullptr;
  admin::Counter* frames_dropped = nullptr;
  admin::Counter* frames_skipped = nullptr;
  admin::Counter* map_sets = nullptr;
  admin::Histogram* processing_seconds = nullptr;
  admin::Histogram* update_latency_seconds = nullptr;
  admin::Histogram* map_set_seconds = nullptr;
};

// A frame as it waits for a worker: the message as it arrived, and when.
struct FrameJob {
  wire::CameraFrame frame;
  Clock::time_point received;
};

// Sends one encoded message (wire::encode) to the session's client; thread-safe; a no-op when
// detached.
using Sink = std::function<void(std::vector<std::uint8_t>)>;

class Session : public std::enable_shared_from_this<Session> {
 public:
  Session(std::string id, std::string device_id, const SessionEnv& env);
  ~Session();

  // A checkpointed session from DATA/sessions/<id>/, or nullptr when there is none;
  // InputError when it is damaged.
  static std::shared_ptr<Session> load(const std::string& id, const SessionEnv& env);

  const std::string& id() const { return id_; }
  const std::string& device_id() const { return device_id_; }

  // The camera the frames come from. The first call creates the capture state, linearising
  // with the device's calibrated curve (DATA/responses/<device>.json) or sRGB. Later calls
  // describe the same camera, or the same size with refined optics (a browser's focal length
  // from the marker's views; at most kMaxCameraChanges a session): the map so far is kept and
  // later frames use the new intrinsics. Returns why not, or empty.
  std::string set_camera(const CameraIntrinsics& camera);
  bool has_camera() const;

  // The connected client: where messages go, and the tile coding its Hello accepts.
  void attach(Sink sink, wire::TileCoding tile_coding = wire::TileCoding::ZstdHalf);
  void detach();
  bool attached() const;
  Clock::time_point last_activity() const;

  void submit(FrameJob job);               // newest wins
  std::string request_maps(MapRequest r);  // empty, or why the request is refused
  // Response calibration from one view at several exposures (JPEGs, exposure x gain each), on
  // the worker pool; answers with a CalibrationResult.
  void calibrate(std::vector<std::vector<std::uint8_t>> jpegs, std::vector<double> times,
                 std::string method);
  std::uint64_t frames_processed() const;

  // Called periodically: when frames stopped arriving for a moment and the map changed since
  // the last map set, computes one now (the user has paused or finished capturing).
  void on_idle(Clock::time_point now);
  void checkpoint();  // writes DATA/sessions/<id>/ if anything changed since the last one
  void shutdown();    // cancels the map computation and waits for running work
  nlohmann::json summary() const;
  std::vector<std::uint8_t> envmap_png() const;  // the live map for people to look at

 private:
  void process();  // on the worker pool
  wire::LightingUpdate lighting_update(const capture::FrameResult& r, std::uint64_t seq);
  void maybe_start_maps();  // with mutex_ held
  void compute_maps_thread(std::stop_token stop, MapRequest request, EnvMap input,
                           std::uint32_t map_set, double coverage, std::uint64_t frames);
  void send(const wire::Message& message);

  std::string id_, device_id_;
  SessionEnv env_;
  mutable std::mutex mutex_;  // everything below
  std::unique_ptr<capture::CaptureSession> capture_;
  std::optional<CameraIntrinsics> camera_;
  static constexpr int kMaxCameraChanges = 16;
  int camera_changes_ = 0;
  std::string response_name_ = "srgb";
  Sink sink_;
  wire::TileCoding tile_coding_ = wire::TileCoding::ZstdHalf;
  std::deque<FrameJob> pending_;  // at most env_.queue_depth frames wait
  bool busy_ = false;             // a process() is queued or running
  std::uint64_t received_ = 0, processed_ = 0, dropped_ = 0, skipped_ = 0, last_sequence_ = 0;
  bool dirty_ = false;
  int checkpoint_generation_ = 0;
  Clock::time_point last_activity_ = Clock::now();
  Clock::time_point last_frame_ = Clock::now();
  std::optional<MapRequest> request_;
  std::uint32_t map_set_ = 0;
  double maps_coverage_ = -1.0;  // coverage the last started map set saw
  std::uint64_t maps_frames_ = 0;
  bool maps_running_ = false, maps_again_ = false;
  std::jthread map_thread_;
  std::mutex process_mutex_;     // held while a frame is processed
  std::mutex checkpoint_mutex_;  // one checkpoint at a time (periodic, Bye, idle, make_room)
};

}  // namespace arlight::daemon
