#include "load_session.hpp"

#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <condition_variable>
#include <mutex>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <optional>
#include <thread>

#include "arlight/net/client_messages.hpp"
#include "arlight/net/client_net.hpp"
#include "arlight/net/frame_pacer.hpp"
#include "arlight/net/unsaved_frames.hpp"

namespace arlight::load {

namespace {

// A loss the session may survive: the network went, or the daemon is momentarily full (a
// restarted daemon that has not reloaded everyone yet, or a hand-over in progress).
bool retryable(const client::ClientError& e) { return e.code() == "Network" || e.code() == "Busy"; }

}  // namespace

FrameJpegs::FrameJpegs(std::vector<std::vector<std::uint8_t>> full, int width, int height,
                       bool reduced)
    : width_(width), height_(height) {
  by_level_[0] = std::move(full);
  for (auto& by_quality : lower_)
    for (auto& frames : by_quality) frames = std::make_unique<Lower[]>(size());
  for (int level = 1; reduced && level < 4; ++level) {
    const int k = 1 << level;
    if (width % k || height % k) break;
    for (const std::vector<std::uint8_t>& jpeg : by_level_[0]) {
      std::vector<std::uint8_t>& out = by_level_[std::size_t(level)].emplace_back();
      const cv::Mat im = jpeg.empty() ? cv::Mat() : cv::imdecode(jpeg, cv::IMREAD_COLOR);
      if (im.empty()) continue;  // an unusable frame stays unusable
      cv::Mat small;
      cv::resize(im, small, cv::Size(width / k, height / k), 0, 0, cv::INTER_AREA);
      cv::imencode(".jpg", small, out, {cv::IMWRITE_JPEG_QUALITY, 90});
    }
  }
}

const std::vector<std::uint8_t>& FrameJpegs::at(std::size_t i, int reduction, int quality) const {
  std::size_t level = 0;
  while (level < 3 && (1 << level) < reduction) ++level;
  while (level > 0 && by_level_[level].empty()) --level;
  const std::vector<std::uint8_t>& made = by_level_[level].at(i);
  const auto& qualities = client::FramePacer::kQualities;
  const auto q = std::find(std::begin(qualities), std::end(qualities), quality);
  if (q == std::begin(qualities) || q == std::end(qualities) || made.empty()) return made;
  Lower& lower = lower_[level][std::size_t(q - std::begin(qualities)) - 1][i];
  std::call_once(lower.once, [&] {
    const cv::Mat im = cv::imdecode(made, cv::IMREAD_COLOR);
    if (!im.empty()) cv::imencode(".jpg", im, lower.jpeg, {cv::IMWRITE_JPEG_QUALITY, quality});
  });
  return lower.jpeg.empty() ? made : lower.jpeg;
}

void run_session(const SessionPlan& plan, const recording::Recording& rec, const FrameJpegs& jpegs,
                 const std::vector<std::size_t>& usable, Clock::time_point start,
                 SessionReport& report) {
  try {
    std::mutex m;
    std::condition_variable answer;  // an update came
    std::uint64_t answered = 0;  // the newest sequence an update has reflected
    client::FramePacer pacer;    // the daemon's frame advice (PROTOCOL.md), frames in flight
    pacer.limit_in_flight(plan.max_in_flight);
    client::UnsavedFrames unsaved;  // for a fail-over (issue 36 §5)
    // Frames up to this one were sent again or delayed by an outage: their latency is the
    // outage's, not the daemon's.
    std::uint64_t outage_frames = 0;
    const auto now_s = [&] { return std::chrono::duration<double>(Clock::now() - start).count(); };
    Clock::time_point first;
    const auto open = [&](const std::string& resume) {
      auto c = std::make_unique<client::Client>();
      if (plan.whole_sets)
        c->set_capabilities({"maps", "jpeg", wire::kCapabilityTilesZstd, wire::kCapabilityTilesHalf});
      plan.connection.apply(*c);
      {
        std::lock_guard lock(m);
        pacer.forget_in_flight();  // a new connection: nothing of the old one will be answered
      }
      c->on_update = [&](const client::LightingUpdate& u) {
        std::lock_guard lock(m);
        // Updates come in sequence order; the frames skipped over were dropped.
        if (u.frame_sequence > answered && u.frame_sequence <= report.sent_ms.size()) {
          answered = u.frame_sequence;
          if (u.frame_sequence > outage_frames) {
            const double ms =
                std::chrono::duration<double, std::milli>(u.received - start).count() -
                report.sent_ms[u.frame_sequence - 1];
            report.latency_ms.push_back(ms);
            report.frame_latency_ms[u.frame_sequence - 1] = ms;
          }
        }
        report.processed = u.frames_processed;
        report.dropped = u.frames_dropped;
        pacer.advise(u);
        unsaved.saved(u.saved_sequence);
        answer.notify_all();
      };
      c->on_map_set_complete = [&](const client::ReceivedMapSet& set) {
        std::lock_guard lock(m);
        if (set.base_set != 0) ++report.map_sets_from_changes;
        report.map_set_ms.push_back(
            std::chrono::duration<double, std::milli>(Clock::now() - first).count());
      };
      // A reconnection tries for a second at a time: a link back from a blackout is used at once.
      const client::Welcome w =
          c->connect(plan.host, plan.port, plan.device, plan.token, "arlight-load", resume,
                     resume.empty() ? std::chrono::seconds(10) : std::chrono::seconds(1));
      if (!resume.empty() && !w.resumed)
        throw client::ClientError("SessionNotFound", "the daemon did not resume " + resume);
      c->send_intrinsics(rec.camera);
      if (plan.ggx_face > 0)
        c->request_maps(client::ggx_request(plan.ggx_face));
      else if (plan.maps)
        c->request_maps({1, 10, 20, 40, 80, 160, 320, 1280}, 128);
      return std::pair{std::move(c), w};
    };
    auto [c, welcome] = open("");
    const std::string session_id = welcome.session_id;
    std::vector<std::unique_ptr<client::Client>> watchers;
    for (int k = 0; k < plan.watchers; ++k) {
      auto w = std::make_unique<client::Client>();
      plan.connection.apply(*w);
      w->watch(session_id);
      w->on_update = [&](const client::LightingUpdate& u) {
        // A watcher stands for another device: its decoding (on the client's network thread)
        // must not take this machine's cores from the daemon and the capturing sessions.
        thread_local const bool niced = setpriority(PRIO_PROCESS, gettid(), 19) == 0;
        (void)niced;
        std::lock_guard lock(m);
        if (u.frame_sequence >= 1 && u.frame_sequence <= report.sent_ms.size())
          report.watcher_latency_ms.push_back(
              std::chrono::duration<double, std::milli>(u.received - start).count() -
              report.sent_ms[u.frame_sequence - 1]);
      };
      try {
        w->connect(plan.host, plan.port, plan.device, plan.token, "arlight-load watcher");
        watchers.push_back(std::move(w));
      } catch (const client::ClientError&) {
        std::lock_guard lock(m);
        ++report.watchers_failed;
      }
    }
    std::uint64_t map_sets_before = 0;  // of the connections before this one
    const auto period = std::chrono::duration<double>(1.0 / plan.rate);
    // This session's frames start `phase` of a frame period late (see --phases).
    first = Clock::now() + std::chrono::duration_cast<Clock::duration>(period * plan.phase);
    std::optional<Clock::time_point> lost_since;
    Outage outage;
    Clock::time_point next_attempt;
    // Kept frames waiting to go (after a resume), as fast as the daemon answers them.
    const auto send_waiting = [&](client::Client& to) {
      for (;;) {
        client::UnsavedFrames::Frame f;
        {
          std::lock_guard lock(m);
          const client::UnsavedFrames::Frame* next = unsaved.next_waiting();
          if (!next || !pacer.may_resend(now_s())) return;
          f = *next;
          unsaved.sent_next();
          pacer.sent(now_s(), f.sequence);
        }
        try {
          to.send_jpeg_frame(f.sequence, f.info, f.width, f.height, f.jpeg);
        } catch (const client::ClientError&) {
          return;  // noticed before the next frame; a resume sends it again
        }
      }
    };
    int reduction = 1;  // the advice's, as of the last frame it allowed
    int quality = client::FramePacer::kMaxQuality;  // likewise
    std::uint64_t received_before = 0;  // bytes of the connections before this one
    std::optional<std::uint64_t> received_at_first_pass;
    for (std::uint64_t k = 0;; ++k) {
      if (k == usable.size()) {  // the recording's first pass is over
        received_at_first_pass = received_before + c->bytes_received();
        report.first_pass_s = std::chrono::duration<double>(Clock::now() - first).count();
      }
      const auto due = first + std::chrono::duration_cast<Clock::duration>(period * double(k));
      if (due - first > std::chrono::duration<double>(plan.duration)) break;
      for (;;) {  // until the frame is due; kept frames go meanwhile as updates make room
        if (!lost_since) send_waiting(*c);
        std::unique_lock lock(m);
        if (answer.wait_until(lock, due) == std::cv_status::timeout) break;
      }
      if (!lost_since) {
        const auto e = c->server_error();
        // A link gone quiet (a blackout) counts as lost: a new connection gets through the
        // moment it is back, while the old one's TCP backs off for seconds (issue 36 §3).
        const bool stalled = plan.reconnect_s > 0 && c->stalled();
        if (e || !c->connected() || stalled) {
          const client::ClientError err(
              e ? e->first : "Network",
              e ? e->second : stalled ? "no answer for 1.5 s" : "connection lost");
          if (stalled) c->close();
          if (plan.reconnect_s <= 0 || !retryable(err)) throw err;
          lost_since = Clock::now(), next_attempt = Clock::now();
          outage = {std::chrono::duration<double>(*lost_since - start).count(), 0, 0, 0, 0};
          outage.lost = unsaved.given_up();  // until the resume: those given up before it
          map_sets_before += c->map_sets_completed();
          received_before += c->bytes_received();
        }
      }
      if (lost_since && Clock::now() >= next_attempt) {
        try {
          auto [fresh, w] = open(session_id);
          std::lock_guard lock(m);
          // What the resumed session lacks goes first (send_waiting below).
          unsaved.welcomed(w.last_sequence);
          outage.to_resend = unsaved.size() - unsaved.waiting_unsent();
          outage.lost = unsaved.given_up() - outage.lost;
          outage.seconds = std::chrono::duration<double>(Clock::now() - *lost_since).count();
          outage_frames = report.sent;
          report.outages.push_back(outage);
          c = std::move(fresh);
          lost_since.reset();
        } catch (const client::ClientError& e) {
          if (!retryable(e)) throw;
          if (Clock::now() - *lost_since > std::chrono::duration<double>(plan.reconnect_s))
            throw client::ClientError(e.code(), "no daemon resumed the session within " +
                                                    std::to_string(plan.reconnect_s) +
                                                    " s: " + e.what());
          next_attempt = Clock::now() + std::chrono::milliseconds(100);
        }
      }
      const std::size_t i = usable[(k + plan.first_frame) % usable.size()];
      const auto& f = rec.frames[i];
      const FrameInfo info{double(k) / plan.rate, f.exposure, f.gain, f.orientation};
      std::uint64_t sequence;
      bool send_now;
      const std::vector<std::uint8_t>* jpeg = nullptr;  // FrameJpegs keeps it
      {
        std::lock_guard lock(m);
        // Without a daemon, or behind kept frames still to go, the frame waits its turn.
        send_now = !lost_since && !unsaved.waiting();
        if (send_now && plan.follow_advice) {
          const client::FramePacer::Decision d =
              pacer.frame_due(now_s(), jpegs.width(), jpegs.height(), plan.rate);
          report.held_back = pacer.held_back(), report.held_in_flight = pacer.held_in_flight();
          if (!d.send) continue;
          reduction = d.reduction, quality = d.quality;
        }
        sequence = ++report.sent;
        report.sent_ms.push_back(
            std::chrono::duration<double, std::milli>(Clock::now() - start).count());
        report.frame_latency_ms.push_back(std::nan(""));
        jpeg = &jpegs.at(i, reduction, quality);
        report.bytes_sent += jpeg->size();
        pacer.encoded(jpeg->size(), jpegs.width() / reduction, jpegs.height() / reduction, quality);
        report.quality_sum += quality;
        // Without a daemon a phone's newest frames wait, as many as it keeps in flight.
        const std::size_t max_unsent =
            plan.follow_advice ? std::size_t(std::max(plan.max_in_flight, 0)) : 0;
        unsaved.keep(sequence, info, rec.camera.width / reduction, rec.camera.height / reduction,
                     *jpeg, send_now, max_unsent);
        if (send_now) pacer.sent(now_s(), sequence);
        if (lost_since) ++outage.delayed;
      }
      if (send_now) {
        try {
          c->send_jpeg_frame(sequence, info, rec.camera.width / reduction,
                             rec.camera.height / reduction, *jpeg);
        } catch (const client::ClientError&) {  // noticed before the next frame
        }
      }
      if (!lost_since) send_waiting(*c);
    }
    if (lost_since) throw client::ClientError("Network", "the session ended without a daemon");
    // Let the kept frames go and the last updates arrive.
    const auto end = Clock::now() + std::chrono::seconds(5);
    for (;;) {
      send_waiting(*c);
      std::unique_lock lock(m);
      if ((answered >= report.sent && !unsaved.waiting()) || Clock::now() >= end || !c->connected())
        break;
      answer.wait_until(lock, std::min(end, Clock::now() + std::chrono::milliseconds(100)));
    }
    {
      std::lock_guard lock(m);
      report.resent = unsaved.resent();
      report.advised_frame_bytes = pacer.advised_frame_bytes();
      report.replaced = unsaved.replaced();
      report.lost = unsaved.given_up_unsent() + unsaved.waiting_unsent();
    }
    if (const auto e = c->server_error()) throw client::ClientError(e->first, e->second);
    report.map_sets = map_sets_before + c->map_sets_completed();
    const std::uint64_t received = received_before + c->bytes_received();
    report.bytes_received_first_pass = received_at_first_pass.value_or(received);
    report.bytes_received_after = received - report.bytes_received_first_pass;
    if (!received_at_first_pass)
      report.first_pass_s = std::chrono::duration<double>(Clock::now() - first).count();
    c->bye();
    for (auto& w : watchers) {
      report.watcher_updates += w->updates_received();
      report.watcher_map_sets += w->map_sets_completed();
      if (w->server_error() || !w->connected()) ++report.watchers_failed;
      w->close();
    }
  } catch (const std::exception& e) {
    report.failed = true;
    report.error = e.what();
  }
}

}  // namespace arlight::load
