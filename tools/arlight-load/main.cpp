// arlight-load: N concurrent replaying sessions against arlightd for a bounded time; reports
// frames sent / processed / dropped, frame-to-update latency percentiles, map sets, errors.
#include <CLI/CLI.hpp>
#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <mutex>
#include <nlohmann/json.hpp>
#include <thread>

#include "arlight/atomic_file.hpp"
#include "arlight/client_net.hpp"
#include "arlight/error.hpp"
#include "arlight/recording.hpp"
#include "arlight/wire.hpp"

using namespace arlight;
using Clock = std::chrono::steady_clock;

namespace {

struct SessionReport {
  bool failed = false;
  std::string error;
  std::uint64_t sent = 0, processed = 0, dropped = 0, map_sets = 0;
  std::vector<double> latency_ms;
  std::vector<double> map_set_ms;  // from the first frame to each completed map set
  // Per frame (index = sequence - 1): when it was sent (ms since the run started) and its
  // latency (NaN: no update reflects it, i.e. it was dropped or never answered).
  std::vector<double> sent_ms, frame_latency_ms;
};

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const double k = p / 100.0 * double(v.size() - 1);
  const std::size_t i = std::size_t(std::floor(k));
  const std::size_t j = std::min(v.size() - 1, i + 1);
  return v[i] + (v[j] - v[i]) * (k - double(i));
}

void run_session(const std::string& host, std::uint16_t port, const std::string& device,
                 const std::string& token, const recording::Recording& rec,
                 const std::vector<std::vector<std::uint8_t>>& jpegs,
                 const std::vector<std::size_t>& usable, double rate, double duration, bool maps,
                 double phase, std::size_t first_frame, const client::TlsOptions& tls,
                 bool websocket, Clock::time_point start, SessionReport& report) {
  try {
    client::Client c;
    c.use_tls(tls);
    c.use_websocket(websocket);
    std::mutex m;
    std::uint64_t answered = 0;  // the newest sequence an update has reflected
    Clock::time_point first;
    c.on_update = [&](const client::LightingUpdate& u) {
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
    c.on_map_set_complete = [&](const client::MapSet&) {
      std::lock_guard lock(m);
      report.map_set_ms.push_back(
          std::chrono::duration<double, std::milli>(Clock::now() - first).count());
    };
    c.connect(host, port, device, token, "arlight-load");
    c.send_intrinsics(rec.camera);
    if (maps) c.request_maps({1, 10, 20, 40, 80, 160, 320, 1280}, 128);
    const auto period = std::chrono::duration<double>(1.0 / rate);
    // This session's frames start `phase` of a frame period late (see --phases).
    first = Clock::now() + std::chrono::duration_cast<Clock::duration>(period * phase);
    for (std::uint64_t k = 0;; ++k) {
      const auto due = first + std::chrono::duration_cast<Clock::duration>(period * double(k));
      if (due - first > std::chrono::duration<double>(duration)) break;
      std::this_thread::sleep_until(due);
      if (const auto e = c.server_error()) throw client::ClientError(e->first, e->second);
      const std::size_t i = usable[(k + first_frame) % usable.size()];
      const auto& f = rec.frames[i];
      {
        std::lock_guard lock(m);
        report.sent_ms.push_back(
            std::chrono::duration<double, std::milli>(Clock::now() - start).count());
        report.frame_latency_ms.push_back(std::nan(""));
      }
      c.send_jpeg_frame(k + 1, {double(k) / rate, f.exposure, f.gain, f.orientation},
                        rec.camera.width, rec.camera.height, jpegs[i]);
      ++report.sent;
    }
    // Let the last updates arrive.
    c.wait_for(
        [&] {
          std::lock_guard lock(m);
          return report.processed + report.dropped >= report.sent;
        },
        std::chrono::seconds(5));
    if (const auto e = c.server_error()) throw client::ClientError(e->first, e->second);
    report.map_sets = c.map_sets_completed();
    c.bye();
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
        run_session(host, port, device.empty() ? rec.device_id : device, token, rec, jpegs, usable,
                    rate, duration, maps, spread ? double(s) / sessions : 0.0,
                    spread ? std::size_t(s) * usable.size() / std::size_t(sessions) : 0, tls, websocket, start,
                    reports[std::size_t(s)]);
      });
    for (auto& t : threads) t.join();

    nlohmann::json j;
    std::vector<double> all;
    std::uint64_t sent = 0, processed = 0, dropped = 0, map_sets = 0;
    int failed = 0;
    j["errors"] = nlohmann::json::array();
    j["per_session"] = nlohmann::json::array();
    for (std::size_t s = 0; s < reports.size(); ++s) {
      const SessionReport& r = reports[s];
      sent += r.sent, processed += r.processed, dropped += r.dropped, map_sets += r.map_sets;
      all.insert(all.end(), r.latency_ms.begin(), r.latency_ms.end());
      if (r.failed) {
        ++failed;
        j["errors"].push_back("session " + std::to_string(s) + ": " + r.error);
      }
      j["per_session"].push_back({{"frames_sent", r.sent},
                                  {"frames_processed", r.processed},
                                  {"frames_dropped", r.dropped},
                                  {"map_sets_completed", r.map_sets},
                                  {"map_set_ms", r.map_set_ms},
                                  {"latency_ms_p50", percentile(r.latency_ms, 50)},
                                  {"latency_ms_p99", percentile(r.latency_ms, 99)},
                                  {"failed", r.failed}});
    }
    j["sessions"] = sessions;
    j["phases"] = phases;
    j["failed"] = failed;
    j["frames_sent"] = sent;
    j["frames_processed"] = processed;
    j["frames_dropped"] = dropped;
    j["latency_ms"] = {
        {"p50", percentile(all, 50)}, {"p95", percentile(all, 95)}, {"p99", percentile(all, 99)}};
    j["map_sets_completed"] = map_sets;
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
