#include "session.hpp"

#include <algorithm>
#include <boost/asio/post.hpp>
#include <cmath>
#include <cstring>
#include <numbers>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "arlight/admin/admin_http.hpp"
#include "arlight/capture/calibration.hpp"
#include "arlight/common/error.hpp"
#include "arlight/common/hdr_io.hpp"
#include "arlight/common/light_files.hpp"
#include "arlight/common/light_sources.hpp"
#include "arlight/common/resample.hpp"
#include "arlight/lighting/ggx.hpp"
#include "arlight/lighting/lighting.hpp"
#include "map_set_stream.hpp"
#include "priority.hpp"

namespace arlight::daemon {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

bool same_camera(const CameraIntrinsics& a, const CameraIntrinsics& b) {
  return a.width == b.width && a.height == b.height && a.fx == b.fx && a.fy == b.fy &&
         a.cx == b.cx && a.cy == b.cy && a.distortion == b.distortion;
}

}  // namespace

CameraResponse device_response(const SessionEnv& env, const std::string& device) {
  try {
    if (auto r = capture::ResponseStore(env.data_dir / "responses").find(device)) return *r;
  } catch (const InputError&) {
  }
  return CameraResponse::srgb();
}

fs::path session_dir(const SessionEnv& env, const std::string& id) {
  return env.data_dir / "sessions" / id;
}

Session::Session(std::string id, std::string device_id, const SessionEnv& env, SessionLease lease)
    : id_(std::move(id)),
      device_id_(std::move(device_id)),
      env_(env),
      frames_(env.queue_depth),
      maps_(std::chrono::duration_cast<Clock::duration>(
          std::chrono::duration<double>(env.map_interval_s))),
      lease_(std::move(lease)),
      watchers_(env.max_watchers) {}

Session::~Session() { shutdown(); }

std::string Session::set_camera(const CameraIntrinsics& camera, bool exposure_unknown) {
  const CameraResponse response = device_response(env_, device_id_);
  std::lock_guard serial(process_mutex_);  // no frame is being added while the camera changes
  std::lock_guard lock(mutex_);
  if (camera_) {
    // The same camera, or refined optics (a browser's focal length from the marker's views),
    // and a client that reports exposure or not (it may have resumed another one's session):
    // the map so far stays, the frames from now on are taken as this client sends them.
    const bool same = same_camera(*camera_, camera);
    capture::CaptureOptions o = capture_->options();
    if (same && o.estimate_exposure == exposure_unknown) return {};
    if (!same) {
      if (camera.width != camera_->width || camera.height != camera_->height)
        return "the session's camera is " + std::to_string(camera_->width) + "x" +
               std::to_string(camera_->height) + "; start a new session for another size";
      if (camera_changes_ >= kMaxCameraChanges)
        return "the session's intrinsics changed " + std::to_string(kMaxCameraChanges) +
               " times already; start a new session";
    }
    try {  // the map, the contributors and the drift stay
      capture_->set_device_camera(0, camera, exposure_unknown);
    } catch (const std::invalid_argument& e) {
      return e.what();
    }
    if (!same) {
      camera_ = camera;
      ++camera_changes_;
      dirty_ = true;
    }
    return {};
  }
  capture::CaptureOptions o;
  o.layout = capture::capture_layout_for(env_.map_size);
  o.fill = env_.fill;
  o.estimate_exposure = exposure_unknown;
  o.align_every = std::max(1, env_.align_every);
  o.align_max_width = std::max(32, env_.align_max_width);
  o.align_async = true;  // a frame never waits for feature matching
  try {
    capture_ = std::make_unique<capture::CaptureSession>(camera, response, o);
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  camera_ = camera;
  response_name_ = response.name();
  dirty_ = true;
  return {};
}

bool Session::has_camera() const {
  std::lock_guard lock(mutex_);
  return camera_.has_value();
}

std::uint64_t Session::attach(ClientLink client) {
  std::lock_guard lock(mutex_);
  sink_ = std::move(client.send);
  disconnect_ = std::move(client.disconnect);
  bulk_begun_ = std::move(client.bulk_begun);
  client_sets_.clear();
  tile_coding_ = client.tile_coding;
  advisor_.reset();
  if (client.exposure_advice) advisor_.emplace();
  uplink_.reset();
  // A connection's map request is its own (every client sends RequestMaps after its Hello when
  // it wants maps): a client resuming the session without one gets no more sets computed for
  // the previous connection's request. A set already running still streams (a client that
  // reconnected mid-set with the same request can use it; others drop it).
  request_.reset();
  previews_.reset();
  ggx_previews_.reset();
  maps_.resume();
  last_activity_ = Clock::now();
  return ++attachment_;
}

void Session::detach(std::uint64_t attachment) {
  std::lock_guard lock(mutex_);
  if (attachment != attachment_) return;  // a newer connection has the session
  join_tokens_.clear();  // the session's device left: its join links end
  sink_ = nullptr;
  disconnect_ = nullptr;
  bulk_begun_ = nullptr;
  last_activity_ = Clock::now();
}

bool Session::attached() const {
  std::lock_guard lock(mutex_);
  return bool(sink_);
}

Clock::time_point Session::last_activity() const {
  std::lock_guard lock(mutex_);
  return last_activity_;
}

std::uint64_t Session::frames_processed() const {
  std::lock_guard lock(mutex_);
  return processed_;
}

std::uint64_t Session::newest_sequence() const {
  std::lock_guard lock(mutex_);
  return newest_sequence_.value_or(0);
}

std::uint64_t Session::handled_sequence() const {
  // Frames wait in sequence order: everything before the oldest waiting one was handled.
  if (const auto oldest = frames_.oldest_sequence()) return *oldest > 0 ? *oldest - 1 : 0;
  return newest_sequence_.value_or(0);
}

std::uint64_t Session::watch(WatcherSet::Watcher watcher, const EncodedMessage& welcome) {
  const std::uint64_t id = watchers_.add(std::move(watcher), welcome);
  if (!id) return 0;
  if (env_.watchers) env_.watchers->add(1);
  std::lock_guard serial(process_mutex_);
  std::lock_guard lock(mutex_);
  if (watchers_.size() == 1 && watcher_request()) {
    // The first watcher of a session that streams no chain: one is computed now, so a settled
    // room lights the watcher too (later ones get it at once, and each set after the map moves).
    maps_.request_changed();
    maybe_start_maps();
  }
  return id;
}

void Session::unwatch(std::uint64_t watcher) {
  if (watchers_.remove(watcher) && env_.watchers) env_.watchers->add(-1);
}

void Session::send(const wire::Message& message, std::optional<BulkGroup> bulk,
                   Audience audience) {
  Sink sink;
  {
    std::lock_guard lock(mutex_);
    if (audience != Audience::Watchers) sink = sink_;
  }
  // Encoded once, here on the worker, not on the network; the same bytes go to the watchers,
  // who keep the newest update and whole set for those who join later (so even with none).
  const auto bytes = std::make_shared<const std::vector<std::uint8_t>>(wire::encode(message));
  if (sink) sink(bytes, bulk);
  if (audience != Audience::Client) watchers_.publish(message, bytes, bulk);
}

std::optional<std::uint32_t> Session::begin_client_set(std::uint32_t id, std::uint32_t lane) {
  std::function<std::optional<std::uint64_t>(std::uint32_t)> begun;
  {
    std::lock_guard lock(mutex_);
    begun = bulk_begun_;
  }
  if (!begun) return std::nullopt;
  // The set the connection has begun writing, after this session's earlier sets were queued:
  // it will be written whole, so the client will hold it (a set queued but not begun yet is
  // replaced by this one). No answer: whole.
  return client_sets_.begin(id, begun(lane).value_or(0));
}

void Session::submit(FrameJob job) {
  std::lock_guard lock(mutex_);
  uplink_.arrived(job.arrival, job.received);
  // A frame the session has already had: a client that resumed sends the frames its checkpoint
  // may lack again (issue 36 §5), and the ones it did have must not count twice.
  if (newest_sequence_ && job.frame.sequence <= *newest_sequence_) {
    ++duplicates_;
    if (env_.frames_duplicate) env_.frames_duplicate->inc();
    return;
  }
  newest_sequence_ = job.frame.sequence;
  env_.frames_received->inc();
  ++received_;
  last_activity_ = Clock::now();
  maps_.frame_arrived(last_activity_);
  // The darker frame the exposure advice asked for stays (one per advice).
  const std::size_t dropped = frames_.push(std::move(job), [this](const FrameJob& waiting) {
    return advisor_ && advisor_->is_advised(waiting.frame.info.exposure * waiting.frame.info.gain);
  });
  dropped_ += dropped;
  if (dropped) env_.frames_dropped->inc(double(dropped));
  if (frames_.begin_turn()) {
    if (env_.frame_path) env_.frame_path->frames_began();
    boost::asio::post(*env_.workers, [self = shared_from_this()] { self->process(); });
  }
}

// One frame a turn: when the session has another waiting, it goes to the back of the worker
// pool's queue, behind the frames of the other sessions (a session with two frames waiting
// used to keep a worker for both while the others' frames waited: the load test's tail).
void Session::process() {
  std::lock_guard serial(process_mutex_);
  std::optional<std::pair<std::uint64_t, FrameJob>> next;
  {
    std::lock_guard lock(mutex_);
    if (capture_) next = take_frame();
    if (!next) {
      end_frame_turn();
      return;
    }
  }
  if (next->first == 0)
    process_own(std::move(next->second));
  else
    process_contributed(next->first, std::move(next->second));
  {
    std::lock_guard lock(mutex_);
    // After the update went: a map set's input (a copy of the map) is not on the frame's path.
    maybe_start_maps();
    if (!frames_waiting() || !capture_) {
      end_frame_turn();
      return;
    }
  }
  boost::asio::post(*env_.workers, [self = shared_from_this()] { self->process(); });
}

void Session::process_own(FrameJob job) {
  const auto t0 = Clock::now();
  capture::FrameResult r;
  wire::CameraFrame& frame = job.frame;
  if (frame.format == wire::PixelFormat::Jpeg) {
    r = capture_->add_encoded(frame.data, frame.info);
  } else {
    cv::Mat rgb(int(frame.height), int(frame.width), CV_8UC3, frame.data.data()), bgr;
    cv::cvtColor(rgb, bgr, cv::COLOR_RGB2BGR);
    r = capture_->add_image(bgr, frame.info);
  }
  env_.processing_seconds->observe(std::chrono::duration<double>(Clock::now() - t0).count());
  wire::LightingUpdate update;
  std::optional<wire::ExposureAdvice> advice;
  {
    std::lock_guard lock(mutex_);
    if (r.used) {
      ++processed_;
      env_.frames_processed->inc();
      if (r.unchanged) {  // it agreed with the map: nothing new to checkpoint or compute
        ++unchanged_, ++unchanged_run_;
        if (env_.frames_unchanged) env_.frames_unchanged->inc();
        if (r.glanced) {
          ++glanced_;
          if (env_.frames_glanced) env_.frames_glanced->inc();
        }
      } else {
        ++merged_;
        unchanged_run_ = 0;
        dirty_ = true;
      }
    } else {
      ++skipped_;
      env_.frames_skipped->inc();
    }
    last_sequence_ = std::max(last_sequence_, frame.sequence);
    update = lighting_update(r, frame.sequence, r.used ? r.orientation : frame.info.orientation,
                             frame.info.timestamp);
    coverage_ = update.coverage;
    // Frames of unknown exposure cannot be told one (the client cannot set it either).
    if (advisor_ && !capture_->options().estimate_exposure)
      if (const auto e = advisor_->after_frame(r))
        advice = wire::ExposureAdvice{frame.sequence, *e, float(r.clipped_unmeasured)};
  }
  if (advice) send(*advice);  // first: the client's next frame should already follow it
  send(update);
  env_.update_latency_seconds->observe(
      std::chrono::duration<double>(Clock::now() - job.received).count());
}

void Session::end_frame_turn() {
  frames_.end_turn();
  if (env_.frame_path) env_.frame_path->frames_ended();
}

void Session::set_location(const wire::Location& location) {
  std::lock_guard lock(mutex_);
  sun_.set_location(location, Clock::now());  // the next update checks at once
}

wire::LightingUpdate Session::lighting_update(const capture::FrameResult& r, std::uint64_t seq,
                                              const glm::dquat& camera, double time,
                                              bool guide) {
  const ShCoeffs& sh = capture_->sh();
  DominantLight light = sh_dominant_light(sh);
  sun_.check(Clock::now(),
             [&] { return capture::brightest_region(capture_->measured_environment()); });
  if (sun_.state() == SunState::Confirmed) light.direction = glm::vec3(sun_.direction());
  wire::LightingUpdate update{.frame_sequence = seq,
          .frame_used = r.used,
          .reason = r.skipped_reason,
          .sh = sh,
          .dominant_direction = light.direction,
          .dominant_colour = light.colour,
          .coverage = float(capture_->coverage()),
          .frames_processed = processed_,
          .frames_dropped = dropped_,
          .estimated = float(capture_->estimated_fraction()),
          .frame_exposure = r.used ? r.exposure_gain : 0.0,
          .sun_state = sun_.state(),
          .sun_direction = glm::vec3(sun_.direction()),
          .advised_width = std::uint16_t(camera_->width / capture_->frame_reduction()),
          .advised_height = std::uint16_t(camera_->height / capture_->frame_reduction()),
          .advised_fps = unchanged_run_ >= kSettledFrames ? kSettledFps : kChangingFps,
          .saved_sequence = saved_sequence_,
          .advised_frame_bytes = uplink_.frame_bytes(Clock::now()),
          .light_error = 0,  // state_uncertainty's
          .light_error_zones = 0,
          .light_error_map = {},
          .next_view = std::nullopt,
          .next_view_gain = 0};
  state_uncertainty(update, camera, time, guide);
  return update;
}

void Session::state_uncertainty(wire::LightingUpdate& update, const glm::dquat& camera,
                                double time, bool guide) {
  if (capture_->options().fill == capture::Fill::None) return;  // not stated: nothing is filled
  const capture::LightUncertainty& u = capture_->uncertainty();
  update.light_error = float(std::min(u.mean(), double(wire::kLightErrorUnknown)));
  update.light_error_zones = std::uint8_t(u.map_zones());
  update.light_error_map.reserve(u.map().size());
  for (const float e : u.map())
    update.light_error_map.push_back(std::uint8_t(std::clamp(std::lround(100.0f * e), 0L, 255L)));
  if (!guide) return;
  // Proposed from where the camera looks now (-Z of the frame's orientation).
  const glm::dvec3 looking = glm::normalize(camera * glm::dvec3(0.0, 0.0, -1.0));
  if (const auto view = view_guide_.next(u, looking, time)) {
    update.next_view = glm::normalize(glm::vec3(view->direction));
    update.next_view_gain = float(std::clamp(view->gain, 0.0, double(wire::kLightErrorUnknown)));
  }
}

std::string Session::request_maps(MapRequest r) {
  if (r.kind == wire::MapKind::Ggx) {
    const int max_face = int(std::min<std::uint32_t>(env_.limits.max_map_size, 1u << 12));
    if (r.size < 1 || r.size > max_face || !std::has_single_bit(unsigned(r.size)))
      return "RequestMaps: a GGX chain's size (level 0's face) must be a power of two up to " +
             std::to_string(max_face) + ", not " + std::to_string(r.size);
    if (wire::ggx_level_count(std::uint32_t(r.size), r.levels) == 0)
      return "RequestMaps: " + std::to_string(r.levels) + " levels from face " +
             std::to_string(r.size) + " go below one texel a face";
    if (r.specular_lights < 0 || r.specular_lights > kMaxSpecularLights)
      return "RequestMaps: specular_lights must be in [0, " + std::to_string(kMaxSpecularLights) +
             "], not " + std::to_string(r.specular_lights);
  } else {
    if (r.specular_lights != 0)
      return "RequestMaps: specular_lights is for a GGX chain (kind Ggx), not the Phong maps";
    if (r.shininess.empty() || r.shininess.size() > env_.limits.max_maps)
      return "RequestMaps: between 1 and " + std::to_string(env_.limits.max_maps) +
             " shininess values";
    for (double s : r.shininess)
      if (!(s >= 1.0 && s <= 1e6)) return "RequestMaps: shininess must be in [1, 1e6]";
    if (r.size < 8 || std::uint32_t(r.size) > env_.limits.max_map_size)
      return "RequestMaps: size must be in [8, " + std::to_string(env_.limits.max_map_size) + "]";
    try {
      lighting::parse_method(r.method);
    } catch (const InputError& e) {
      return std::string("RequestMaps: ") + e.what();
    }
  }
  std::lock_guard serial(process_mutex_);  // a set's input is read from the capture
  std::lock_guard lock(mutex_);
  request_ = std::move(r);
  previews_.reset();
  ggx_previews_.reset();
  client_sets_.clear();     // the new request's first set goes whole
  maps_.request_changed();  // a new request is computed at once
  dirty_ = true;
  maybe_start_maps();
  return {};
}

// Map sets follow the map (issue 16 §3; the rules are MapSetScheduler's). While frames arrive,
// sets are previews (MapSetJob::preview: from the map reduced to about twice the output's
// texels); once they pause, a full one follows (from on_idle, or when the running set ends).
void Session::maybe_start_maps() {
  const MapSetScheduler::Decision d =
      maps_.decide({.time = Clock::now(),
                    .frames_merged = merged_,
                    .frames_waiting = frames_.active(),
                    .can_compute = (request_ || watcher_request()) && capture_ &&
                                   capture_->coverage() > 0.0});
  if (d.kind == MapSetScheduler::Decision::Kind::StartAt) start_maps_at(d.at);
  if (d.kind == MapSetScheduler::Decision::Kind::StartNow) start_map_set(d.preview);
}

std::optional<MapRequest> Session::watcher_request() const {
  if (watchers_.size() == 0 || (request_ && request_->kind == wire::MapKind::Ggx)) return {};
  return MapRequest{.shininess = {}, .size = kWatcherGgxFace, .projection = Projection::Cube,
                    .method = "auto", .kind = wire::MapKind::Ggx, .levels = 0};
}

MapSetJob Session::map_set_job(const MapRequest& request, bool preview, bool for_watchers) {
  const bool ggx = request.kind == wire::MapKind::Ggx;
  // A preview's input: the map reduced (when that is smaller) to preview_input_layout() of the
  // output, or for a GGX chain to the preview chain's face, with the share of each texel that
  // was measured; a full set's: the map itself.
  EnvLayout reduced =
      ggx ? ggx_preview_input(request, capture_->layout())
          : preview_input_layout(EnvLayout::for_size(request.projection, request.size));
  if (reduced.texel_count() >= capture_->layout().texel_count()) reduced = capture_->layout();
  capture::CaptureSession::Reduced snapshot =
      preview ? capture_->reduced_environment(reduced)
              : capture::CaptureSession::Reduced{capture_->environment(), {}};
  MapSetJob job{.request = request,
                .input = std::move(snapshot.env),
                .id = ++map_set_,
                .coverage = capture_->coverage(),
                .frames = processed_,  // unchanged frames are in it too: they agreed with it
                .preview = preview,
                .frame_path = env_.frame_path,
                .tile_coding = [this] {
                  std::lock_guard lock(mutex_);
                  return tile_coding_;
                }};
  job.for_watchers = for_watchers;
  if (for_watchers) job.tile_coding = [] { return wire::TileCoding::Planar; };  // mostly browsers
  std::shared_ptr<lighting::GgxUpdater>& ggx_updater =
      for_watchers ? watcher_ggx_previews_ : ggx_previews_;
  if (preview && ggx) {
    if (!ggx_updater) ggx_updater = std::make_shared<lighting::GgxUpdater>(ggx_preview_spec(request));
    job.ggx_previews = ggx_updater;
    job.measured = std::move(snapshot.measured);
  } else if (preview) {
    if (!previews_)
      previews_ = std::make_shared<lighting::MapUpdater>(
          request.shininess, EnvLayout::for_size(request.projection, request.size),
          lighting::parse_method(request.method));
    job.previews = previews_;
    job.measured = std::move(snapshot.measured);
  }
  return job;
}

void Session::start_map_set(bool preview) {
  // The client's own set, and the watchers' GGX chain when the client streams none (each set is
  // computed in turn on the same thread; the client never gets the watchers' tiles).
  std::vector<MapSetJob> jobs;
  if (request_) jobs.push_back(map_set_job(*request_, preview, false));
  if (const auto w = watcher_request()) jobs.push_back(map_set_job(*w, preview, true));
  if (map_thread_.joinable()) map_thread_.join();  // finished already (the scheduler was Idle)
  // `this`, not a shared_ptr: the thread must never hold the last reference (~Session joins
  // it); ~Session stops and joins it before any member goes away.
  map_thread_ = std::jthread([this, jobs = std::move(jobs)](std::stop_token stop) mutable {
    compute_maps_thread(stop, std::move(jobs));
  });
}

void Session::start_maps_at(Clock::time_point when) {
  if (maps_timer_armed_ || !env_.workers) return;
  if (!maps_timer_) maps_timer_ = std::make_unique<boost::asio::steady_timer>(*env_.workers);
  maps_timer_armed_ = true;
  maps_timer_->expires_at(when);
  maps_timer_->async_wait([weak = weak_from_this()](const boost::system::error_code& ec) {
    if (ec) return;
    if (const auto self = weak.lock()) {
      std::lock_guard serial(self->process_mutex_);
      std::lock_guard lock(self->mutex_);
      self->maps_timer_armed_ = false;
      self->maybe_start_maps();
    }
  });
}

void Session::on_idle(Clock::time_point) {
  std::lock_guard serial(process_mutex_);
  std::lock_guard lock(mutex_);
  // A set the interval deferred, or the full one after a preview, when no frame came since
  // to start it.
  maybe_start_maps();
}

void Session::compute_maps_thread(std::stop_token stop, std::vector<MapSetJob> jobs) {
  for (const MapSetJob& job : jobs) {
    // The set's progress, tiles and completion as bulk data of its kind's lane (an Error of
    // the computation is not).
    const BulkGroup group{std::uint32_t(job.request.kind), job.id};
    const auto send_as = [&](const wire::Message& m) {
      const bool part = std::holds_alternative<wire::MapTile>(m) ||
                        std::holds_alternative<wire::Progress>(m) ||
                        std::holds_alternative<wire::MapSetComplete>(m);
      return part ? std::optional(group) : std::nullopt;
    };
    // The client's set as what changed since one it holds, when it takes changes.
    const std::optional<std::uint32_t> base =
        job.for_watchers ? std::nullopt : begin_client_set(job.id, group.lane);
    const auto sink = [&](const wire::Message& m, Audience to) {
      if (!job.for_watchers) return send(m, send_as(m), to);
      if (to == Audience::Client) return;
      watchers_.publish(m, std::make_shared<const std::vector<std::uint8_t>>(wire::encode(m)),
                        send_as(m));
    };
    const double seconds =
        stream_map_set(job, stop, sink, base ? &client_sets_ : nullptr, base.value_or(0));
    if (seconds >= 0.0) {
      env_.map_sets->inc();
      env_.map_set_seconds->observe(seconds);
    }
  }
  std::lock_guard lock(mutex_);
  if (maps_.finished() && !stop.stop_requested()) {
    // Start the next set from a fresh thread: this one cannot join itself.
    boost::asio::post(*env_.workers, [self = shared_from_this()] {
      std::lock_guard serial(self->process_mutex_);
      std::lock_guard lock(self->mutex_);
      self->maybe_start_maps();
    });
  }
}

void Session::calibrate(std::vector<std::vector<std::uint8_t>> jpegs, std::vector<double> times,
                        std::string method) {
  boost::asio::post(*env_.workers, [self = shared_from_this(), jpegs = std::move(jpegs),
                                    times = std::move(times), method = std::move(method)] {
    bool stored = false;
    std::string message;
    try {
      const auto m = capture::parse_calibration_method(method.empty() ? "robertson" : method);
      if (!m) throw InputError("method must be robertson or debevec, not '" + method + "'");
      std::vector<cv::Mat> images;
      for (std::size_t i = 0; i < jpegs.size(); ++i) {
        cv::Mat im = cv::imdecode(jpegs[i], cv::IMREAD_COLOR);
        if (im.empty()) throw InputError("frame " + std::to_string(i) + " does not decode");
        images.push_back(im);
      }
      const CameraResponse r = capture::calibrate_response(images, times, *m);
      capture::ResponseStore(self->env_.data_dir / "responses").save(self->device_id_, r);
      stored = true;
      message = "stored for device " + self->device_id_;
      // A session that has not merged a frame yet starts over with the new curve.
      std::lock_guard serial(self->process_mutex_);
      std::lock_guard lock(self->mutex_);
      if (self->capture_ && self->processed_ == 0 && self->capture_->device_count() == 1) {
        capture::CaptureOptions o = self->capture_->options();
        self->capture_ = std::make_unique<capture::CaptureSession>(*self->camera_, r, o);
        self->response_name_ = r.name();
        message += "; this session uses it";
      }
    } catch (const std::exception& e) {
      message = e.what();
    }
    self->send(wire::CalibrationResult{stored, method, std::uint32_t(jpegs.size()), message});
  });
}

void Session::shutdown() {
  // The map thread is taken out under the lock and joined outside it: maybe_start_maps()
  // (under the lock) joins and replaces map_thread_, and two joins of one thread hung arlightd
  // on SIGTERM (a set's follow-up, posted before, joined it while this did). No set starts
  // after this until a client attaches again.
  std::jthread running;
  {
    std::lock_guard lock(mutex_);
    if (maps_timer_) maps_timer_->cancel();
    maps_timer_armed_ = false;
    maps_.stop();
    running = std::move(map_thread_);
  }
  if (running.joinable()) {
    running.request_stop();
    running.join();
  }
  std::lock_guard serial(process_mutex_);  // a frame being processed finishes first
}

json Session::summary() const {
  const std::size_t watchers = watchers_.size();
  std::lock_guard lock(mutex_);
  json j = {{"id", id_},
            {"device_id", device_id_},
            {"connected", bool(sink_)},
            {"frames_received", received_},
            {"frames_processed", processed_},
            {"frames_dropped", dropped_},
            {"frames_skipped", skipped_},
            {"frames_duplicate", duplicates_},
            {"frames_unchanged", unchanged_},
            {"frames_glanced", glanced_},
            {"last_sequence", last_sequence_},
            {"map_sets", map_set_},
            {"watchers", watchers >= contributors_.size() ? watchers - contributors_.size() : 0},
            {"contributors", contributors_.size()},
            {"exposure_advice", advisor_ ? advisor_->advised() : 0},
            {"exposure_advice_followed", advisor_ ? advisor_->followed() : 0},
            {"coverage", coverage_},
            {"sun", sun_state_name(sun_.state())}};
  return j;
}

std::vector<std::uint8_t> Session::envmap_png() const {
  EnvMap env(EnvLayout::for_size(Projection::AngleMap, 8));
  {
    std::lock_guard serial(process_mutex_);
    std::lock_guard lock(mutex_);
    if (capture_) env = capture_->environment();
  }
  // Shown as an angle map of the daemon's map size, whatever the capture layout.
  const EnvLayout shown = EnvLayout::for_size(Projection::AngleMap, env_.map_size);
  if (env.layout.projection() != Projection::AngleMap) env = resample(env, shown);
  std::vector<std::uint8_t> rgb = preview_pixels(env.image.view());  // as the PNG files
  cv::Mat out;
  cv::cvtColor(cv::Mat(env.image.height(), env.image.width(), CV_8UC3, rgb.data()), out,
               cv::COLOR_RGB2BGR);
  std::vector<std::uint8_t> png;
  cv::imencode(".png", out, png);
  return png;
}

std::shared_ptr<const Session::LightFiles> Session::light_files() const {
  std::lock_guard cached(light_files_mutex_);
  std::optional<EnvMap> env;
  ShCoeffs sh;
  std::uint64_t frames = 0;
  {
    std::lock_guard serial(process_mutex_);
    std::lock_guard lock(mutex_);
    frames = merged_;
    if (light_files_ && light_files_frames_ == frames) return light_files_;
    if (capture_) {
      env = capture_->environment();
      sh = capture_->sh();
    }
  }
  if (!env) throw admin::NotReady("session '" + id_ + "' has no map yet (no frame received)");
  const lighting::GgxChain chain =
      lighting::compute_ggx_chain(*env, {.face = kLightFileFace, .min_face = 16});
  const std::vector<EnvMap> maps = chain.maps();
  LightFilesInput light;
  light.roughness = chain.roughness();
  light.sh = sh;
  light.primary = primary_light(*env, sh);
  light.specular = maps;
  light.source = "arlightd session " + id_;
  light_files_ = std::make_shared<const LightFiles>(LightFiles{light_json(light), specular_ktx2(light)});
  light_files_frames_ = frames;
  if (env_.light_files) env_.light_files->inc();
  return light_files_;
}

}  // namespace arlight::daemon
