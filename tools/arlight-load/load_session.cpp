#include "load_session.hpp"

#include <sys/resource.h>
#include <unistd.h>

#include <cmath>
#include <mutex>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <optional>
#include <thread>

#include "arlight/net/client_messages.hpp"
#include "arlight/net/client_net.hpp"
#include "arlight/net/frame_pacer.hpp"

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

const std::vector<std::vector<std::uint8_t>>& FrameJpegs::at(int reduction) const {
  std::size_t level = 0;
  while (level < 3 && (1 << level) < reduction) ++level;
  while (level > 0 && by_level_[level].empty()) --level;
  return by_level_[level];
}

void run_session(const SessionPlan& plan, const recording::Recording& rec, const FrameJpegs& jpegs,
                 const std::vector<std::size_t>& usable, Clock::time_point start,
                 SessionReport& report) {
  try {
    std::mutex m;
    std::uint64_t answered = 0;  // the newest sequence an update has reflected
    client::FramePacer pacer;    // the daemon's frame advice (PROTOCOL.md), frames in flight
    pacer.limit_in_flight(plan.max_in_flight);
    Clock::time_point first;
    const auto open = [&](const std::string& resume) {
      auto c = std::make_unique<client::Client>();
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
          const double ms = std::chrono::duration<double, std::milli>(u.received - start).count() -
                            report.sent_ms[u.frame_sequence - 1];
          report.latency_ms.push_back(ms);
          report.frame_latency_ms[u.frame_sequence - 1] = ms;
        }
        report.processed = u.frames_processed;
        report.dropped = u.frames_dropped;
        pacer.advise(u);
      };
      c->on_map_set_complete = [&](const client::ReceivedMapSet&) {
        std::lock_guard lock(m);
        report.map_set_ms.push_back(
            std::chrono::duration<double, std::milli>(Clock::now() - first).count());
      };
      const client::Welcome w =
          c->connect(plan.host, plan.port, plan.device, plan.token, "arlight-load", resume);
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
    for (std::uint64_t k = 0;; ++k) {
      const auto due = first + std::chrono::duration_cast<Clock::duration>(period * double(k));
      if (due - first > std::chrono::duration<double>(plan.duration)) break;
      std::this_thread::sleep_until(due);
      if (!lost_since) {
        const auto e = c->server_error();
        if (e || !c->connected()) {
          const client::ClientError err(e ? e->first : "Network",
                                        e ? e->second : "connection lost");
          if (plan.reconnect_s <= 0 || !retryable(err)) throw err;
          lost_since = Clock::now(), next_attempt = Clock::now();
          outage = {std::chrono::duration<double>(*lost_since - start).count(), 0, 0, 0};
          map_sets_before += c->map_sets_completed();
        }
      }
      if (lost_since && Clock::now() >= next_attempt) {
        try {
          auto [fresh, w] = open(session_id);
          std::lock_guard lock(m);
          // Frames lost in earlier outages are in neither count: they do not count again.
          std::uint64_t kept = w.frames_processed + report.dropped;
          for (const Outage& o : report.outages) kept += o.lost_after_checkpoint;
          outage.lost_after_checkpoint = report.sent > kept ? report.sent - kept : 0;
          outage.seconds = std::chrono::duration<double>(Clock::now() - *lost_since).count();
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
      if (lost_since) {
        ++outage.not_sent;
        continue;
      }
      const std::size_t i = usable[(k + plan.first_frame) % usable.size()];
      const auto& f = rec.frames[i];
      int reduction = 1;
      {
        std::lock_guard lock(m);
        if (plan.follow_advice) {
          const double now_s = std::chrono::duration<double>(Clock::now() - start).count();
          const client::FramePacer::Decision d =
              pacer.frame_due(now_s, jpegs.width(), jpegs.height(), plan.rate);
          report.held_back = pacer.held_back(), report.held_in_flight = pacer.held_in_flight();
          if (!d.send) continue;
          reduction = d.reduction;
          pacer.sent(now_s, report.sent + 1);  // the sequence it goes with
        }
        report.sent_ms.push_back(
            std::chrono::duration<double, std::milli>(Clock::now() - start).count());
        report.frame_latency_ms.push_back(std::nan(""));
        ++report.sent;
      }
      try {
        const std::vector<std::uint8_t>& jpeg = jpegs.at(reduction)[i];
        report.bytes_sent += jpeg.size();
        c->send_jpeg_frame(report.sent, {double(k) / plan.rate, f.exposure, f.gain, f.orientation},
                           rec.camera.width / reduction, rec.camera.height / reduction, jpeg);
      } catch (const client::ClientError&) {  // noticed before the next frame
      }
    }
    if (lost_since) throw client::ClientError("Network", "the session ended without a daemon");
    // Let the last updates arrive.
    c->wait_for(
        [&] {
          std::lock_guard lock(m);
          std::uint64_t lost = 0;  // in outages: never to be answered
          for (const Outage& o : report.outages) lost += o.lost_after_checkpoint;
          return report.processed + report.dropped + lost >= report.sent;
        },
        std::chrono::seconds(5));
    if (const auto e = c->server_error()) throw client::ClientError(e->first, e->second);
    report.map_sets = map_sets_before + c->map_sets_completed();
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
