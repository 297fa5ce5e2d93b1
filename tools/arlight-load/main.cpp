// arlight-load: N concurrent replaying sessions against arlightd for a bounded time; reports
// frames sent / processed / dropped, frame-to-update latency percentiles, map sets, errors.
#include <CLI/CLI.hpp>
#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <thread>

#include "arlight/atomic_file.hpp"
#include "arlight/client_net.hpp"
#include "arlight/error.hpp"
#include "arlight/recording.hpp"
#include "arlight/wire.hpp"

using namespace arlight;
using Clock = std::chrono::steady_clock;

namespace {

// One time a session lost its daemon and resumed (--reconnect).
struct Outage {
  double at_s = 0, seconds = 0;  // when it was noticed (since the start) and how long it lasted
  std::uint64_t not_sent = 0;    // frames due while there was no daemon
  // Frames the lost daemon had been sent but not checkpointed: sent until the loss, minus what
  // the resumed session holds (the Welcome's frames_processed) and had dropped.
  std::uint64_t lost_after_checkpoint = 0;
};

struct SessionReport {
  bool failed = false;
  std::string error;
  std::uint64_t sent = 0, processed = 0, dropped = 0, map_sets = 0;
  std::vector<double> latency_ms;
  std::vector<double> map_set_ms;  // from the first frame to each completed map set
  // Per frame (index = sequence - 1): when it was sent (ms since the run started) and its
  // latency (NaN: no update reflects it, i.e. it was dropped or never answered).
  std::vector<double> sent_ms, frame_latency_ms;
  std::vector<Outage> outages;
};

// The median interval between a session's consecutive map sets that completed while it was
// still sending (the map changing): issue 16 §3's figure. 0 with fewer than two.
double median_map_set_interval(const std::vector<double>& map_set_ms, double duration_s);

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const double k = p / 100.0 * double(v.size() - 1);
  const std::size_t i = std::size_t(std::floor(k));
  const std::size_t j = std::min(v.size() - 1, i + 1);
  return v[i] + (v[j] - v[i]) * (k - double(i));
}

double median_map_set_interval(const std::vector<double>& map_set_ms, double duration_s) {
  std::vector<double> intervals;
  for (std::size_t k = 1; k < map_set_ms.size(); ++k)
    if (map_set_ms[k] <= 1000.0 * duration_s)
      intervals.push_back(map_set_ms[k] - map_set_ms[k - 1]);
  return percentile(intervals, 50);
}

struct SessionPlan {
  std::string host, device, token;
  std::uint16_t port = 0;
  double rate = 30, duration = 10;
  bool maps = false;
  double phase = 0;
  std::size_t first_frame = 0;
  client::TlsOptions tls;
  bool websocket = false;
  // How long a session may be without its daemon before it counts as failed (0: any loss
  // fails it); while it is, it reconnects (at once, then every 100 ms) and resumes.
  double reconnect_s = 0;
};

// A loss the session may survive: the network went, or the daemon is momentarily full (a
// restarted daemon that has not reloaded everyone yet, or a hand-over in progress).
bool retryable(const client::ClientError& e) { return e.code() == "Network" || e.code() == "Busy"; }

void run_session(const SessionPlan& plan, const recording::Recording& rec,
                 const std::vector<std::vector<std::uint8_t>>& jpegs,
                 const std::vector<std::size_t>& usable, Clock::time_point start,
                 SessionReport& report) {
  try {
    std::mutex m;
    std::uint64_t answered = 0;  // the newest sequence an update has reflected
    Clock::time_point first;
    const auto open = [&](const std::string& resume) {
      auto c = std::make_unique<client::Client>();
      c->use_tls(plan.tls);
      c->use_websocket(plan.websocket);
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
      };
      c->on_map_set_complete = [&](const client::MapSet&) {
        std::lock_guard lock(m);
        report.map_set_ms.push_back(
            std::chrono::duration<double, std::milli>(Clock::now() - first).count());
      };
      const client::Welcome w =
          c->connect(plan.host, plan.port, plan.device, plan.token, "arlight-load", resume);
      if (!resume.empty() && !w.resumed)
        throw client::ClientError("SessionNotFound", "the daemon did not resume " + resume);
      c->send_intrinsics(rec.camera);
      if (plan.maps) c->request_maps({1, 10, 20, 40, 80, 160, 320, 1280}, 128);
      return std::pair{std::move(c), w};
    };
    auto [c, welcome] = open("");
    const std::string session_id = welcome.session_id;
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
      {
        std::lock_guard lock(m);
        report.sent_ms.push_back(
            std::chrono::duration<double, std::milli>(Clock::now() - start).count());
        report.frame_latency_ms.push_back(std::nan(""));
        ++report.sent;
      }
      try {
        c->send_jpeg_frame(report.sent, {double(k) / plan.rate, f.exposure, f.gain, f.orientation},
                           rec.camera.width, rec.camera.height, jpegs[i]);
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
  } catch (const std::exception& e) {
    report.failed = true;
    report.error = e.what();
  }
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"arlight-load: load-test arlightd with concurrent replayed sessions"};
  std::string server, token, recording_dir, device, json_path;
  int sessions = 4;
  double duration = 10, rate = 30;
  bool maps = false;
  app.add_option("--server", server, "arlightd HOST:PORT")->required();
  app.add_option("--token", token, "the device's token")->required();
  app.add_option("--recording", recording_dir, "recording whose frames are sent (cyclically)")
      ->required();
  app.add_option("--sessions", sessions, "concurrent sessions")->capture_default_str();
  app.add_option("--duration", duration, "seconds of sending")->capture_default_str();
  app.add_option("--rate", rate, "frames per second per session")->capture_default_str();
  app.add_option("--device", device, "device id (default: the recording's)");
  app.add_flag("--maps", maps, "also request the 8 thesis maps at 128 in every session");
  std::string phases = "spread";
  app.add_option("--phases", phases,
                 "spread: session s sends at s/N of the frame period and starts at s/N of the "
                 "recording, as independent phones would; sync: the same frame from every "
                 "session at once (the worst case)")
      ->check(CLI::IsMember({"spread", "sync"}))
      ->capture_default_str();
  app.add_option("--json", json_path, "write the report here");
  std::string trace_path;
  app.add_option("--trace", trace_path,
                 "write every frame as CSV: session,sequence,sent_ms,latency_ms (empty when no "
                 "update reflects it)");
  double reconnect_s = 0;
  app.add_option("--reconnect", reconnect_s,
                 "seconds a session may be without its daemon (killed, restarted, behind a "
                 "balancer) while it reconnects and resumes; 0: a lost connection fails it")
      ->capture_default_str();
  client::TlsOptions tls;
  app.add_flag("--tls", tls.enabled, "connect with TLS (trusting the system's CAs)");
  app.add_option("--tls-ca", tls.ca_file, "connect with TLS, trusting this PEM CA/certificate");
  bool websocket = false;
  app.add_flag("--websocket", websocket,
               "connect to arlightd's web port (--server HOST:WEBPORT) over wss://.../ws, as the "
               "browser client does (with --tls-ca for a self-signed certificate)");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  try {
    if (sessions < 1 || sessions > 1000) throw InputError("--sessions must be in [1, 1000]");
    if (!(duration > 0 && duration <= 3600)) throw InputError("--duration must be in (0, 3600]");
    if (!(rate > 0 && rate <= 1000)) throw InputError("--rate must be in (0, 1000]");
    std::string host;
    std::uint16_t port = 0;
    wire::parse_endpoint(server, host, port);
    const bool spread = phases == "spread";
    const recording::Recording rec = recording::read_recording(recording_dir);
    std::vector<std::vector<std::uint8_t>> jpegs(rec.frames.size());
    std::vector<std::size_t> usable;
    recording::FrameReader reader(rec);
    while (auto item = reader.next()) {
      jpegs[item->index] = std::move(item->jpeg);
      usable.push_back(item->index);
    }
    if (usable.empty()) throw InputError("'" + recording_dir + "' has no usable frames");

    std::vector<SessionReport> reports(static_cast<std::size_t>(sessions));
    std::vector<std::thread> threads;
    const auto start = Clock::now();
    for (int s = 0; s < sessions; ++s)
      threads.emplace_back([&, s] {
        SessionPlan plan;
        plan.host = host, plan.port = port, plan.token = token;
        plan.device = device.empty() ? rec.device_id : device;
        plan.rate = rate, plan.duration = duration, plan.maps = maps;
        plan.phase = spread ? double(s) / sessions : 0.0;
        plan.first_frame = spread ? std::size_t(s) * usable.size() / std::size_t(sessions) : 0;
        plan.tls = tls, plan.websocket = websocket, plan.reconnect_s = reconnect_s;
        run_session(plan, rec, jpegs, usable, start, reports[std::size_t(s)]);
      });
    for (auto& t : threads) t.join();

    nlohmann::json j;
    std::vector<double> all;
    std::uint64_t sent = 0, processed = 0, dropped = 0, map_sets = 0;
    std::vector<double> map_set_intervals;  // each session's median, of those with two or more
    int failed = 0;
    j["errors"] = nlohmann::json::array();
    j["per_session"] = nlohmann::json::array();
    nlohmann::json outages = nlohmann::json::array();
    double worst_lost_s = 0;  // frames lost in one outage of one session, in seconds of frames
    for (std::size_t s = 0; s < reports.size(); ++s) {
      const SessionReport& r = reports[s];
      sent += r.sent, processed += r.processed, dropped += r.dropped, map_sets += r.map_sets;
      all.insert(all.end(), r.latency_ms.begin(), r.latency_ms.end());
      if (const double i = median_map_set_interval(r.map_set_ms, duration); i > 0.0)
        map_set_intervals.push_back(i);
      if (r.failed) {
        ++failed;
        j["errors"].push_back("session " + std::to_string(s) + ": " + r.error);
      }
      j["per_session"].push_back(
          {{"frames_sent", r.sent},
           {"frames_processed", r.processed},
           {"frames_dropped", r.dropped},
           {"map_sets_completed", r.map_sets},
           {"map_set_ms", r.map_set_ms},
           {"map_set_interval_ms_median", median_map_set_interval(r.map_set_ms, duration)},
           {"latency_ms_p50", percentile(r.latency_ms, 50)},
           {"latency_ms_p99", percentile(r.latency_ms, 99)},
           {"failed", r.failed}});
      for (const Outage& o : r.outages) {
        outages.push_back({{"session", s},
                           {"at_s", o.at_s},
                           {"seconds", o.seconds},
                           {"frames_not_sent", o.not_sent},
                           {"frames_lost_after_checkpoint", o.lost_after_checkpoint}});
        worst_lost_s = std::max(worst_lost_s, double(o.not_sent + o.lost_after_checkpoint) / rate);
      }
    }
    j["outages"] = outages;
    j["worst_outage_frames_lost_s"] = worst_lost_s;
    j["sessions"] = sessions;
    j["phases"] = phases;
    j["failed"] = failed;
    j["frames_sent"] = sent;
    j["frames_processed"] = processed;
    j["frames_dropped"] = dropped;
    j["latency_ms"] = {
        {"p50", percentile(all, 50)}, {"p95", percentile(all, 95)}, {"p99", percentile(all, 99)}};
    j["map_sets_completed"] = map_sets;
    // While the sessions were sending: the median over sessions of each one's median interval
    // between map sets, and the slowest session's.
    j["map_set_interval_ms"] = {
        {"median", percentile(map_set_intervals, 50)},
        {"worst_session", map_set_intervals.empty() ? 0.0
                                                    : *std::max_element(map_set_intervals.begin(),
                                                                        map_set_intervals.end())}};
    j["rate"] = rate;
    j["duration_s"] = duration;
    if (!json_path.empty()) write_file_atomically(json_path, j.dump(2) + "\n");
    if (!trace_path.empty()) {
      std::string csv = "session,sequence,sent_ms,latency_ms\n";
      char line[96];
      for (std::size_t s = 0; s < reports.size(); ++s)
        for (std::size_t k = 0; k < reports[s].sent_ms.size(); ++k) {
          const double ms = reports[s].frame_latency_ms[k];
          std::snprintf(line, sizeof line,
                        std::isnan(ms) ? "%zu,%zu,%.3f,\n" : "%zu,%zu,%.3f,%.3f\n", s, k + 1,
                        reports[s].sent_ms[k], ms);
          csv += line;
        }
      write_file_atomically(trace_path, csv);
    }
    std::printf(
        "%d sessions (%d failed): %llu frames sent, %llu processed, %llu dropped; "
        "latency p50 %.1f ms, p95 %.1f ms, p99 %.1f ms; %llu map sets\n",
        sessions, failed, static_cast<unsigned long long>(sent),
        static_cast<unsigned long long>(processed), static_cast<unsigned long long>(dropped),
        percentile(all, 50), percentile(all, 95), percentile(all, 99),
        static_cast<unsigned long long>(map_sets));
    if (!map_set_intervals.empty())
      std::printf("map sets while sending: every %.0f ms (median session), %.0f ms (slowest)\n",
                  j["map_set_interval_ms"]["median"].get<double>(),
                  j["map_set_interval_ms"]["worst_session"].get<double>());
    if (!outages.empty())
      std::printf("%zu outages survived; the worst lost %.2f s of frames\n", outages.size(),
                  worst_lost_s);
    for (const auto& e : j["errors"]) std::fprintf(stderr, "%s\n", e.get<std::string>().c_str());
    return failed ? 1 : 0;
  } catch (const InputError& e) {
    std::fprintf(stderr, "arlight-load: bad input: %s\n", e.what());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "arlight-load: %s\n", e.what());
    return 1;
  }
}
