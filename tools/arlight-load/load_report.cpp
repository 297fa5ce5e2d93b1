#include "load_report.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace arlight::load {

namespace {

// The median interval between a session's consecutive map sets that completed while it was
// still sending (the map changing): issue 16 §3's figure. 0 with fewer than two.
double median_map_set_interval(const std::vector<double>& map_set_ms, double duration_s) {
  std::vector<double> intervals;
  for (std::size_t k = 1; k < map_set_ms.size(); ++k)
    if (map_set_ms[k] <= 1000.0 * duration_s)
      intervals.push_back(map_set_ms[k] - map_set_ms[k - 1]);
  return percentile(intervals, 50);
}

}  // namespace

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const double k = p / 100.0 * double(v.size() - 1);
  const std::size_t i = std::size_t(std::floor(k));
  const std::size_t j = std::min(v.size() - 1, i + 1);
  return v[i] + (v[j] - v[i]) * (k - double(i));
}

nlohmann::json report_json(const std::vector<SessionReport>& reports, const std::string& phases,
                           double rate, double duration) {
  const int sessions = int(reports.size());
  nlohmann::json j;
  std::vector<double> all;
  std::uint64_t sent = 0, processed = 0, dropped = 0, map_sets = 0, held_back = 0, bytes = 0;
  std::uint64_t map_sets_from_changes = 0;
  std::uint64_t resent = 0, lost = 0;
  std::uint64_t held_in_flight = 0;
  std::uint64_t quality_sum = 0, encoded = 0;  // frames' JPEG qualities and their count
  std::vector<double> watcher_latency;
  std::uint64_t watcher_updates = 0, watcher_map_sets = 0, watchers_failed = 0;
  std::vector<double> map_set_intervals;  // each session's median, of those with two or more
  int failed = 0;
  j["errors"] = nlohmann::json::array();
  j["per_session"] = nlohmann::json::array();
  nlohmann::json outages = nlohmann::json::array();
  double worst_lost_s = 0;  // frames lost in one outage of one session, in seconds of frames
  for (std::size_t s = 0; s < reports.size(); ++s) {
    const SessionReport& r = reports[s];
    sent += r.sent - r.replaced, processed += r.processed, dropped += r.dropped;
    map_sets += r.map_sets, held_back += r.replaced;
    map_sets_from_changes += r.map_sets_from_changes;
    resent += r.resent, lost += r.lost;
    held_back += r.held_back, bytes += r.bytes_sent, held_in_flight += r.held_in_flight;
    quality_sum += r.quality_sum, encoded += r.sent;
    all.insert(all.end(), r.latency_ms.begin(), r.latency_ms.end());
    watcher_latency.insert(watcher_latency.end(), r.watcher_latency_ms.begin(),
                           r.watcher_latency_ms.end());
    watcher_updates += r.watcher_updates, watcher_map_sets += r.watcher_map_sets;
    watchers_failed += r.watchers_failed;
    if (const double i = median_map_set_interval(r.map_set_ms, duration); i > 0.0)
      map_set_intervals.push_back(i);
    if (r.failed) {
      ++failed;
      j["errors"].push_back("session " + std::to_string(s) + ": " + r.error);
    }
    j["per_session"].push_back(
        {{"frames_sent", r.sent - r.replaced},
         {"frames_held_back", r.held_back},
         {"frames_held_in_flight", r.held_in_flight},
         {"bytes_sent", r.bytes_sent},
         {"bytes_per_frame", r.sent ? double(r.bytes_sent) / double(r.sent) : 0.0},
         {"jpeg_quality_mean", r.sent ? double(r.quality_sum) / double(r.sent) : 0.0},
         {"advised_frame_bytes", r.advised_frame_bytes},
         {"frames_processed", r.processed},
         {"frames_dropped", r.dropped},
         {"frames_resent", r.resent},
         {"frames_lost", r.lost},
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
                         {"frames_delayed", o.delayed},
                         {"frames_to_resend", o.to_resend},
                         {"frames_lost", o.lost}});
      worst_lost_s = std::max(worst_lost_s, double(o.lost) / rate);
    }
  }
  j["outages"] = outages;
  j["worst_outage_frames_lost_s"] = worst_lost_s;
  j["sessions"] = sessions;
  j["phases"] = phases;
  j["failed"] = failed;
  j["frames_sent"] = sent;
  j["frames_resent"] = resent;  // after resumes: the checkpoint they resumed from lacked them
  j["frames_lost"] = lost;      // never reached a session (issue 36 §5: 0)
  j["frames_held_back"] = held_back;  // the frame advice asked for fewer, or
  j["frames_held_in_flight"] = held_in_flight;  // (of them) --max-in-flight were unanswered
  // The frames' bytes a second per session: the uplink a phone would use.
  j["upload_bytes_per_s_per_session"] =
      reports.empty() ? 0.0 : double(bytes) / duration / double(reports.size());
  // What a frame took, and the JPEG quality it was encoded at (the daemon's byte advice).
  j["bytes_per_frame"] = encoded ? double(bytes) / double(encoded) : 0.0;
  j["jpeg_quality_mean"] = encoded ? double(quality_sum) / double(encoded) : 0.0;
  // The daemon's bytes a second per session (its messages, before a WebSocket's compression):
  // while the recording's first pass captures the room, and after it, as the same frames come
  // again (the map settled).
  double down_first = 0, down_after = 0;
  for (const SessionReport& r : reports) {
    if (r.first_pass_s > 0) down_first += double(r.bytes_received_first_pass) / r.first_pass_s;
    if (duration > r.first_pass_s + 0.5)
      down_after += double(r.bytes_received_after) / (duration - r.first_pass_s);
  }
  const double n = reports.empty() ? 1.0 : double(reports.size());
  j["download_bytes_per_s_per_session"] = {{"capturing", down_first / n},
                                           {"settled", down_after / n}};
  j["frames_processed"] = processed;
  j["frames_dropped"] = dropped;
  j["latency_ms"] = {
      {"p50", percentile(all, 50)}, {"p95", percentile(all, 95)}, {"p99", percentile(all, 99)}};
  j["map_sets_completed"] = map_sets;
  j["map_sets_from_changes"] = map_sets_from_changes;  // sent as the tiles that changed
  // --watchers: frame sent by its session -> the LightingUpdate at a watcher; their totals.
  j["watchers"] = {{"latency_ms",
                    {{"p50", percentile(watcher_latency, 50)},
                     {"p99", percentile(watcher_latency, 99)}}},
                   {"updates", watcher_updates},
                   {"map_sets_completed", watcher_map_sets},
                   {"failed", watchers_failed}};
  // While the sessions were sending: the median over sessions of each one's median interval
  // between map sets, and the slowest session's.
  j["map_set_interval_ms"] = {
      {"median", percentile(map_set_intervals, 50)},
      {"worst_session", map_set_intervals.empty() ? 0.0
                                                  : *std::max_element(map_set_intervals.begin(),
                                                                      map_set_intervals.end())}};
  j["rate"] = rate;
  j["duration_s"] = duration;
  return j;
}

std::string trace_csv(const std::vector<SessionReport>& reports) {
  std::string csv = "session,sequence,sent_ms,latency_ms\n";
  char line[96];
  for (std::size_t s = 0; s < reports.size(); ++s)
    for (std::size_t k = 0; k < reports[s].sent_ms.size(); ++k) {
      const double ms = reports[s].frame_latency_ms[k];
      std::snprintf(line, sizeof line, std::isnan(ms) ? "%zu,%zu,%.3f,\n" : "%zu,%zu,%.3f,%.3f\n",
                    s, k + 1, reports[s].sent_ms[k], ms);
      csv += line;
    }
  return csv;
}

void print_summary(const nlohmann::json& j) {
  const auto count = [&](const char* key) {
    return static_cast<unsigned long long>(j[key].get<std::uint64_t>());
  };
  const nlohmann::json& latency = j["latency_ms"];
  std::printf(
      "%d sessions (%d failed): %llu frames sent, %llu processed, %llu dropped; "
      "latency p50 %.1f ms, p95 %.1f ms, p99 %.1f ms; %llu map sets\n",
      j["sessions"].get<int>(), j["failed"].get<int>(), count("frames_sent"),
      count("frames_processed"), count("frames_dropped"), latency["p50"].get<double>(),
      latency["p95"].get<double>(), latency["p99"].get<double>(), count("map_sets_completed"));
  std::printf(
      "frames held back by the daemon's advice: %llu (%llu while --max-in-flight were "
      "unanswered); frames of %.1f kB at JPEG quality %.0f (mean); upload %.0f kB/s a session; "
      "download %.0f kB/s capturing, %.0f kB/s settled\n",
      count("frames_held_back"), count("frames_held_in_flight"),
      j["bytes_per_frame"].get<double>() / 1e3, j["jpeg_quality_mean"].get<double>(),
      j["upload_bytes_per_s_per_session"].get<double>() / 1e3,
      j["download_bytes_per_s_per_session"]["capturing"].get<double>() / 1e3,
      j["download_bytes_per_s_per_session"]["settled"].get<double>() / 1e3);
  if (j["map_set_interval_ms"]["median"].get<double>() > 0.0)
    std::printf("map sets while sending: every %.0f ms (median session), %.0f ms (slowest)\n",
                j["map_set_interval_ms"]["median"].get<double>(),
                j["map_set_interval_ms"]["worst_session"].get<double>());
  if (const auto& w = j["watchers"]; w["updates"].get<std::uint64_t>() > 0)
    std::printf("watchers: %llu updates (p50 %.1f ms, p99 %.1f ms after the frame), %llu map "
                "sets, %llu failed\n",
                static_cast<unsigned long long>(w["updates"].get<std::uint64_t>()),
                w["latency_ms"]["p50"].get<double>(), w["latency_ms"]["p99"].get<double>(),
                static_cast<unsigned long long>(w["map_sets_completed"].get<std::uint64_t>()),
                static_cast<unsigned long long>(w["failed"].get<std::uint64_t>()));
  if (!j["outages"].empty())
    std::printf("%zu outages survived; the worst lost %.2f s of frames\n", j["outages"].size(),
                j["worst_outage_frames_lost_s"].get<double>());
  for (const auto& e : j["errors"]) std::fprintf(stderr, "%s\n", e.get<std::string>().c_str());
}

}  // namespace arlight::load
