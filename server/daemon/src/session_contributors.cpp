// Two phones, one room (issue 49 §1; PROTOCOL.md "Contributors"): other devices capturing into a
// session beside its own. Each has its own camera, response and exposure in the capture
// (CaptureSession::add_device), which registers its frames with the map before merging them;
// each gets the session's map sets as a watcher does and the LightingUpdates of its own frames.
// Their frames wait in queues of their own and take turns with the session's on the worker pool,
// so a contributor never pushes out the owner's frames, nor the owner a contributor's.
#include <algorithm>
#include <boost/asio/post.hpp>
#include <cstdio>
#include <random>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "session.hpp"

namespace arlight::daemon {

std::uint64_t Session::join(ContributorLink link, const EncodedMessage& welcome) {
  std::lock_guard serial(process_mutex_);
  std::lock_guard lock(mutex_);
  if (contributors_.size() >= env_.max_contributors) return 0;
  link.watcher.updates = false;  // its own frames' updates come through link.send
  const std::uint64_t watcher = watchers_.add(std::move(link.watcher), welcome);
  if (!watcher) return 0;
  Contributor c(env_.queue_depth);
  c.device_id = std::move(link.device_id);
  c.send = std::move(link.send);
  c.watcher = watcher;
  if (link.exposure_advice) c.advisor.emplace();
  const std::uint64_t id = ++contributors_joined_;
  contributors_.emplace(id, std::move(c));
  last_activity_ = Clock::now();
  if (watchers_.size() == 1 && watcher_request()) {  // as watch(): a chain for it at once
    maps_.request_changed();
    maybe_start_maps();
  }
  return id;
}

void Session::leave(std::uint64_t contributor) {
  std::lock_guard lock(mutex_);
  const auto it = contributors_.find(contributor);
  if (it == contributors_.end()) return;
  watchers_.remove(it->second.watcher);
  contributors_.erase(it);  // its waiting frames go; its device and registration stay
  last_activity_ = Clock::now();
}

std::string Session::new_join_token() {
  std::random_device random;
  std::string token;
  for (int i = 0; i < 4; ++i) {
    char hex[9];
    std::snprintf(hex, sizeof hex, "%08x", unsigned(random()));
    token += hex;
  }
  std::lock_guard lock(mutex_);
  const Clock::time_point now = Clock::now();
  std::erase_if(join_tokens_, [&](const auto& t) { return t.second <= now; });
  while (join_tokens_.size() >= kMaxJoinTokens)  // the one that ends soonest goes
    join_tokens_.erase(std::min_element(join_tokens_.begin(), join_tokens_.end(),
                                        [](const auto& a, const auto& b) { return a.second < b.second; }));
  join_tokens_[token] = now + std::chrono::duration_cast<Clock::duration>(
                                  std::chrono::duration<double>(kJoinTokenSeconds));
  return token;
}

Session::JoinTokenState Session::join_token_state(const std::string& token) const {
  std::lock_guard lock(mutex_);
  const auto it = join_tokens_.find(token);
  if (it == join_tokens_.end()) return JoinTokenState::Unknown;
  return it->second > Clock::now() ? JoinTokenState::Valid : JoinTokenState::Expired;
}

std::size_t Session::contributors() const {
  std::lock_guard lock(mutex_);
  return contributors_.size();
}

std::string Session::set_contributor_camera(std::uint64_t contributor,
                                            const CameraIntrinsics& camera,
                                            bool exposure_unknown) {
  std::string device_id;
  {
    std::lock_guard lock(mutex_);
    const auto it = contributors_.find(contributor);
    if (it == contributors_.end()) return "not a contributor of session " + id_;
    device_id = it->second.device_id;
  }
  const CameraResponse response = device_response(env_, device_id);
  std::lock_guard serial(process_mutex_);
  std::lock_guard lock(mutex_);
  const auto it = contributors_.find(contributor);
  if (it == contributors_.end()) return "not a contributor of session " + id_;
  Contributor& c = it->second;
  if (!capture_) return "session " + id_ + " has no camera of its own yet";
  try {
    if (c.device < 0) {
      if (const auto known = contributor_devices_.find(c.device_id);
          known != contributor_devices_.end()) {
        c.device = known->second;  // joined before: its registration continues
        capture_->set_device_camera(c.device, camera, exposure_unknown);
      } else {
        c.device = capture_->add_device(camera, response, exposure_unknown);
        contributor_devices_[c.device_id] = c.device;
        if (const auto saved = saved_contributors_.find(c.device_id);
            saved != saved_contributors_.end())
          capture_->restore_registration(c.device, saved->second.offset,
                                         saved->second.radiance_scale);
      }
    } else if (!c.camera || c.camera->width != camera.width || c.camera->height != camera.height) {
      return "the contributor's camera is " + std::to_string(c.camera->width) + "x" +
             std::to_string(c.camera->height) + "; join again for another size";
    } else {
      capture_->set_device_camera(c.device, camera, exposure_unknown);
    }
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  c.camera = camera;
  c.exposure_unknown = exposure_unknown;
  return {};
}

bool Session::contributor_has_camera(std::uint64_t contributor) const {
  std::lock_guard lock(mutex_);
  const auto it = contributors_.find(contributor);
  return it != contributors_.end() && it->second.camera.has_value();
}

void Session::submit_contributed(std::uint64_t contributor, FrameJob job) {
  std::lock_guard lock(mutex_);
  const auto it = contributors_.find(contributor);
  if (it == contributors_.end()) return;
  Contributor& c = it->second;
  if (c.newest_sequence && job.frame.sequence <= *c.newest_sequence) {
    ++duplicates_;
    if (env_.frames_duplicate) env_.frames_duplicate->inc();
    return;
  }
  c.newest_sequence = job.frame.sequence;
  env_.frames_received->inc();
  ++c.received;
  last_activity_ = Clock::now();
  maps_.frame_arrived(last_activity_);
  // The darker frame its advice asked for stays (as the session's own device's).
  const std::size_t dropped = c.frames.push(std::move(job), [&c](const FrameJob& waiting) {
    return c.advisor && c.advisor->is_advised(waiting.frame.info.exposure * waiting.frame.info.gain);
  });
  c.dropped += dropped;
  if (dropped) env_.frames_dropped->inc(double(dropped));
  if (frames_.begin_turn()) {  // the session's turn on the pool, whoever's frame it is
    if (env_.frame_path) env_.frame_path->frames_began();
    boost::asio::post(*env_.workers, [self = shared_from_this()] { self->process(); });
  }
}

std::optional<std::pair<std::uint64_t, FrameJob>> Session::take_frame() {
  if (contributors_.empty()) {  // every session's path: nothing to take turns with
    std::optional<FrameJob> job = frames_.take();
    if (!job) return std::nullopt;
    take_turn_ = 0;
    return std::pair{std::uint64_t(0), std::move(*job)};
  }
  std::vector<std::uint64_t> order{0};  // the session's own first, then by joining
  for (const auto& [id, c] : contributors_) order.push_back(id);
  std::size_t start = 0;  // the first after the one taken last, round robin
  for (std::size_t i = 0; i < order.size(); ++i)
    if (order[i] > take_turn_) {
      start = i;
      break;
    }
  for (std::size_t k = 0; k < order.size(); ++k) {
    const std::uint64_t id = order[(start + k) % order.size()];
    std::optional<FrameJob> job = id == 0 ? frames_.take() : contributors_.at(id).frames.take();
    if (!job) continue;
    take_turn_ = id;
    return std::pair{id, std::move(*job)};
  }
  return std::nullopt;
}

bool Session::frames_waiting() const {
  if (!frames_.empty()) return true;
  for (const auto& [id, c] : contributors_)
    if (!c.frames.empty()) return true;
  return false;
}

void Session::process_contributed(std::uint64_t contributor, FrameJob job) {
  int device = -1;
  {
    std::lock_guard lock(mutex_);
    const auto it = contributors_.find(contributor);
    if (it == contributors_.end()) return;  // it left while the frame waited
    device = it->second.device;
  }
  if (device < 0) return;  // frames come after the camera (the connection checks)
  const auto t0 = Clock::now();
  capture::FrameResult r;
  wire::CameraFrame& frame = job.frame;
  if (frame.format == wire::PixelFormat::Jpeg) {
    r = capture_->add_encoded(frame.data, frame.info, device);
  } else {
    cv::Mat rgb(int(frame.height), int(frame.width), CV_8UC3, frame.data.data()), bgr;
    cv::cvtColor(rgb, bgr, cv::COLOR_RGB2BGR);
    r = capture_->add_image(bgr, frame.info, device);
  }
  env_.processing_seconds->observe(std::chrono::duration<double>(Clock::now() - t0).count());
  wire::LightingUpdate update;
  std::optional<wire::ExposureAdvice> advice;
  Sink sink;
  {
    std::lock_guard lock(mutex_);
    const auto it = contributors_.find(contributor);
    if (r.used) {
      env_.frames_processed->inc();
      if (r.unchanged) {
        if (env_.frames_unchanged) env_.frames_unchanged->inc();
      } else {
        ++merged_;  // the map moved: map sets, light files and checkpoints follow
        dirty_ = true;
      }
    } else {
      env_.frames_skipped->inc();
    }
    update = lighting_update(r, frame.sequence, r.used ? r.orientation : frame.info.orientation,
                             frame.info.timestamp, /*guide=*/false);
    coverage_ = update.coverage;
    update.registration =
        r.registered ? wire::Registration::Registered : wire::Registration::Waiting;
    // Its own frames' counts, sizes and rates; nothing of its frames needs keeping for a
    // fail-over (a contributor joins again and registers where it is).
    update.saved_sequence = frame.sequence;
    update.advised_frame_bytes = 0;
    update.advised_fps = kChangingFps;
    if (it != contributors_.end()) {
      Contributor& c = it->second;
      if (r.used) ++c.processed, c.merged += r.unchanged ? 0 : 1;
      else ++c.skipped;
      c.registered = r.registered;
      update.frames_processed = c.processed, update.frames_dropped = c.dropped;
      if (c.camera) {
        const int k = capture_->frame_reduction(device);
        update.advised_width = std::uint16_t(c.camera->width / k);
        update.advised_height = std::uint16_t(c.camera->height / k);
      }
      sink = c.send;
      // Its exposure advice (issue 16 §4) in its own units: the map's times its sensitivity.
      if (c.advisor && !c.exposure_unknown && r.registered)
        if (const auto e = c.advisor->after_frame(r))
          advice = wire::ExposureAdvice{frame.sequence,
                                        *e * capture_->registration(device).radiance_scale,
                                        float(r.clipped_unmeasured)};
    }
  }
  if (advice && sink)  // first: its next frame should already follow it
    sink(std::make_shared<const std::vector<std::uint8_t>>(wire::encode(*advice)), std::nullopt);
  const auto bytes = std::make_shared<const std::vector<std::uint8_t>>(wire::encode(update));
  if (sink) sink(bytes, std::nullopt);
  watchers_.publish(update, bytes);  // watchers see the map grow; contributors take sets only
  env_.update_latency_seconds->observe(
      std::chrono::duration<double>(Clock::now() - job.received).count());
}

}  // namespace arlight::daemon
