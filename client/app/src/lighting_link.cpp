#include "arlight/app/lighting_link.hpp"

#include "arlight/net/client_messages.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <utility>

namespace arlight::client_app {

using namespace std::chrono_literals;

LightingLink::LightingLink(LinkOptions options) : options_(std::move(options)) {
  pacer_.limit_in_flight(options_.max_in_flight);
  thread_ = std::thread([this] { run(); });
}

LightingLink::~LightingLink() {
  stop_ = true;
  changed_.notify_all();
  if (thread_.joinable()) thread_.join();
  std::shared_ptr<client::Client> c;
  {
    std::lock_guard lock(mutex_);
    c = std::move(client_);
  }
  if (c && c->connected()) {
    try {
      c->bye();  // the daemon checkpoints the session
      c->wait_for([&] { return !c->connected(); }, 2s);
    } catch (const client::ClientError&) {
    }
  }
  if (c) c->close();
}

void LightingLink::wait_connected(std::chrono::milliseconds timeout) {
  std::unique_lock lock(mutex_);
  changed_.wait_for(lock, timeout, [&] { return stats_.connected || refused_; });
  if (stats_.connected) return;
  throw client::ClientError(refused_ ? "Unauthorized" : "Network",
                            "no session with " + options_.host + ":" +
                                std::to_string(options_.port) +
                                (stats_.last_error.empty() ? "" : ": " + stats_.last_error));
}

bool LightingLink::wait_for_maps(std::chrono::duration<double> timeout) {
  std::unique_lock lock(mutex_);
  // The set this link asked for: the GGX chain or the Phong maps.
  const auto arrived = [&] {
    return options_.ggx_face > 0 ? lighting_.ggx != nullptr : lighting_.maps != nullptr;
  };
  return changed_.wait_for(lock, timeout, [&] { return arrived() || stop_; }) && arrived();
}

bool LightingLink::connect_once() {
  auto c = std::make_shared<client::Client>();
  c->on_update = [this](const client::LightingUpdate& u) {
    std::lock_guard lock(mutex_);
    lighting_.apply(u);
    pacer_.advise(u);
    unsaved_.saved(link_sequence(u.saved_sequence));
    ++stats_.updates;
    changed_.notify_all();  // room for a kept frame to go again
    if (!stats_.resumes.empty() && stats_.resumes.back().first_coverage < 0)
      stats_.resumes.back().first_coverage = u.coverage;
  };
  c->on_map_set_complete = [this](const client::ReceivedMapSet& m) {
    std::lock_guard lock(mutex_);
    lighting_.apply(std::make_shared<const client::ReceivedMapSet>(m));
    ++stats_.map_sets;
    changed_.notify_all();
  };
  c->on_exposure_advice = [this](const wire::ExposureAdvice& a) {
    std::lock_guard lock(mutex_);
    advice_ = a.exposure;
    if (a.exposure > 0) ++stats_.exposure_advice;
  };
  std::string resume;
  {
    std::lock_guard lock(mutex_);
    resume = stats_.session_id.empty() ? options_.resume_session : stats_.session_id;
  }
  try {
    c->use_tls(options_.tls);
    if (options_.exposure_advice) c->add_capability(wire::kCapabilityExposureAdvice);
    // A reconnection tries for a second at a time: a link back from a blackout is used at once.
    const client::Welcome w =
        c->connect(options_.host, options_.port, options_.device_id, options_.token,
                   "arlight-client", resume, first_handshake_ ? 5000ms : 1000ms);
    c->send_intrinsics(options_.camera);
    if (options_.location &&
        wire::has_capability(w.capabilities, wire::kServerCapabilityLocation)) {
      wire::Location l = *options_.location;
      l.utc_seconds +=
          std::chrono::duration<double>(std::chrono::steady_clock::now() - started_).count();
      c->send_location(l);
    }
    if (options_.ggx_face > 0)
      c->request_maps(client::ggx_request(options_.ggx_face, 0, options_.ggx_lights));
    else if (!options_.shininess.empty())
      c->request_maps(options_.shininess, options_.map_size, options_.projection);
    std::lock_guard lock(mutex_);
    if (!stats_.session_id.empty() && w.session_id != stats_.session_id)
      spdlog::warn("arlightd started a new session {} (the old one is gone)", w.session_id);
    // A session resumed from before this link: its frames so far are numbered up to
    // last_sequence, and the link's follow them (a frame at or below it would be a duplicate).
    if (first_handshake_ && w.resumed) sequence_offset_ = w.last_sequence;
    first_handshake_ = false;
    // What the session lacks of the frames kept goes (again) first (issue 36 §5).
    unsaved_.welcomed(w.resumed ? link_sequence(w.last_sequence) : 0);
    if (w.resumed && w.session_id == resume)
      stats_.resumes.push_back({stats_.frames_sent, w.frames_processed,
                                link_sequence(w.last_sequence), unsaved_.size(), -1.0});
    client_ = std::move(c);
    pacer_.forget_in_flight();  // nothing sent on the old connection will be answered
    stats_.connected = true;
    stats_.session_id = w.session_id;
    ++stats_.connects;
    spdlog::info("connected to arlightd: session {}{}", w.session_id,
                 w.resumed ? " (resumed)" : "");
    changed_.notify_all();
    return true;
  } catch (const client::ClientError& e) {
    std::lock_guard lock(mutex_);
    stats_.last_error = e.what();
    if (e.code() == "Unauthorized") refused_ = true;
    // A session the server no longer has: start a new one on the next attempt.
    if (e.code() == "SessionNotFound") stats_.session_id.clear(), options_.resume_session.clear();
    changed_.notify_all();
    return false;
  }
}

void LightingLink::run() {
  bool warned = false;
  int failures = 0;  // attempts since the last connection: the backoff
  while (!stop_) {
    std::shared_ptr<client::Client> c;
    {
      std::lock_guard lock(mutex_);
      c = client_;
    }
    // A link gone quiet (a blackout): a new connection gets through the moment it is back,
    // while this one's TCP backs off for seconds (issue 36 §3).
    if (c && c->connected() && c->stalled()) {
      spdlog::warn("arlightd has not answered for {} s; reconnecting", client::Client::kStallSeconds);
      c->close();
    }
    if (c && c->connected()) {
      {
        std::lock_guard sending(send_mutex_);
        send_waiting(*c);
      }
      std::unique_lock lock(mutex_);
      changed_.wait_for(lock, 100ms, [&] { return stop_.load(); });
      continue;
    }
    {
      std::lock_guard lock(mutex_);
      if (stats_.connected) {
        stats_.connected = false;
        const auto err = c ? c->server_error() : std::nullopt;
        stats_.last_error = err ? err->first + ": " + err->second : "connection lost";
        // The server refused something this client sends (its camera, a message): sending it
        // again cannot help. Network trouble or a busy server is worth retrying.
        if (err && err->first != "Network" && err->first != "Busy" && err->first != "Internal")
          refused_ = true;
        spdlog::warn("lost arlightd ({}); rendering with the last lighting{}", stats_.last_error,
                     refused_ ? "" : ", reconnecting");
      }
      client_.reset();
      if (refused_) {
        if (!warned) spdlog::error("arlightd refused this device: {}", stats_.last_error);
        warned = true;
      }
    }
    // Right after a loss, at once: a daemon behind a balancer that died is replaced by another
    // in well under a second (deploy/haproxy). Then 0.1, 0.2, 0.4 ... s up to the interval.
    if (!refused_) {
      if (connect_once()) {
        failures = 0;
        continue;
      }
      ++failures;
    }
    const double wait =
        std::min(options_.reconnect_interval_s, 0.1 * double(1 << std::clamp(failures - 1, 0, 10)));
    std::unique_lock lock(mutex_);
    changed_.wait_for(lock, std::chrono::duration<double>(std::max(wait, 0.01)),
                      [&] { return stop_.load(); });
  }
}

bool LightingLink::flush(std::chrono::duration<double> timeout) {
  std::unique_lock lock(mutex_);
  // The link's thread sends them as updates make room.
  return changed_.wait_for(lock, timeout,
                           [&] { return !unsaved_.waiting() || stop_ || refused_; }) &&
         !unsaved_.waiting();
}

client::FramePacer::Decision LightingLink::frame_due(double timestamp, int width, int height) {
  constexpr double kCameraFps = 30.0;  // the jitter the pacer allows: half a frame of it
  std::lock_guard lock(mutex_);
  const client::FramePacer::Decision d = pacer_.frame_due(timestamp, width, height, kCameraFps);
  stats_.frames_held_back = pacer_.held_back();
  stats_.frames_held_in_flight = pacer_.held_in_flight();
  return d;
}

void LightingLink::send_frame(std::uint64_t sequence, const FrameInfo& info, int width, int height,
                              std::span<const std::uint8_t> jpeg, int quality) {
  std::lock_guard sending(send_mutex_);
  std::shared_ptr<client::Client> c;
  bool behind;  // kept frames wait to go first
  std::uint64_t wire;
  {
    std::lock_guard lock(mutex_);
    c = client_;
    behind = unsaved_.waiting();
    wire = wire_sequence(sequence);
    newest_timestamp_ = std::max(newest_timestamp_, info.timestamp);
  }
  bool sent = false;
  if (!behind && c && c->connected()) {
    try {
      c->send_jpeg_frame(wire, info, width, height, jpeg);
      sent = true;
    } catch (const client::ClientError&) {  // the link notices and reconnects
    }
  }
  {
    std::lock_guard lock(mutex_);
    // A live camera's newest frames wait for a daemon, as many as it keeps in flight; a
    // recording's every frame.
    unsaved_.keep(sequence, info, width, height, jpeg, sent,
                  std::size_t(std::max(options_.max_in_flight, 0)));
    pacer_.encoded(jpeg.size(), width, height, quality);
    ++stats_.frames_encoded, stats_.frame_bytes += jpeg.size(), stats_.jpeg_quality_sum += quality;
    if (sent) {
      ++stats_.frames_sent;
      pacer_.sent(info.timestamp, wire);
    } else {
      ++stats_.frames_delayed;
    }
  }
  if (!sent && c && c->connected()) send_waiting(*c);
}

void LightingLink::send_waiting(client::Client& c) {
  for (;;) {
    client::UnsavedFrames::Frame f;
    std::uint64_t wire;
    {
      std::lock_guard lock(mutex_);
      const client::UnsavedFrames::Frame* next = unsaved_.next_waiting();
      if (!next || !pacer_.may_resend(newest_timestamp_)) return;
      f = *next;
      wire = wire_sequence(f.sequence);
    }
    try {
      c.send_jpeg_frame(wire, f.info, f.width, f.height, f.jpeg);
    } catch (const client::ClientError&) {
      return;  // the link notices and reconnects; the frame still waits
    }
    std::lock_guard lock(mutex_);
    const std::uint64_t resent_before = unsaved_.resent();
    unsaved_.sent_next();
    if (unsaved_.resent() == resent_before) ++stats_.frames_sent;
    pacer_.sent(newest_timestamp_, wire);
  }
}

Lighting LightingLink::lighting() const {
  std::lock_guard lock(mutex_);
  return lighting_;
}

std::optional<double> LightingLink::take_exposure_advice() {
  std::lock_guard lock(mutex_);
  return std::exchange(advice_, std::nullopt);
}

LinkStats LightingLink::stats() const {
  std::lock_guard lock(mutex_);
  LinkStats s = stats_;
  s.refused = refused_;
  s.frames_resent = unsaved_.resent();
  s.frames_held_back += unsaved_.replaced();  // a newer frame went in their place
  s.frames_not_sent = unsaved_.given_up_unsent() + unsaved_.waiting_unsent();
  s.advised_frame_bytes = pacer_.advised_frame_bytes();
  return s;
}

}  // namespace arlight::client_app
