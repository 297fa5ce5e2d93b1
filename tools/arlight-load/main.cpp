// arlight-load: N concurrent replaying sessions against arlightd for a bounded time
// (load_session.cpp); reports frames sent / processed / dropped, frame-to-update latency
// percentiles, map sets, outages and errors (load_report.cpp).
#include <CLI/CLI.hpp>
#include <cstdio>
#include <thread>

#include "arlight/common/atomic_file.hpp"
#include "arlight/common/error.hpp"
#include "arlight/flags/connection_flags.hpp"
#include "arlight/protocol/recording.hpp"
#include "arlight/protocol/wire.hpp"
#include "load_report.hpp"
#include "load_session.hpp"

using namespace arlight;
using namespace arlight::load;

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
  int ggx_face = 0;
  app.add_option("--ggx", ggx_face,
                 "request the GGX chain from this face (a power of two) down to 16 in every "
                 "session instead of --maps");
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
  bool ignore_advice = false;
  app.add_flag("--ignore-advice", ignore_advice,
               "send every frame at the recording's size and --rate whatever the daemon's frame "
               "advice says (a raw flood, as before it)");
  int max_in_flight = 2;
  app.add_option("--max-in-flight", max_in_flight,
                 "frames a session keeps sent and not yet answered by a LightingUpdate; the "
                 "newer ones wait for an answer (0: no limit; --ignore-advice: none either)")
      ->capture_default_str();
  int watchers = 0;
  app.add_option("--watchers", watchers,
                 "devices watching each session (Hello's watch_session, the device's token): "
                 "they receive its updates and map sets and send nothing")
      ->capture_default_str();
  double reconnect_s = 0;
  app.add_option("--reconnect", reconnect_s,
                 "seconds a session may be without its daemon (killed, restarted, behind a "
                 "balancer) while it reconnects and resumes; 0: a lost connection fails it")
      ->capture_default_str();
  bool whole_sets = false;
  app.add_flag("--whole-sets", whole_sets,
               "take every map set whole, as clients did before sets were sent as what changed "
               "(a Hello without maps:deltas; for comparisons)");
  tools::ConnectionFlags connection;
  connection.add_to(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  try {
    if (sessions < 1 || sessions > 1000) throw InputError("--sessions must be in [1, 1000]");
    if (!(duration > 0 && duration <= 3600)) throw InputError("--duration must be in (0, 3600]");
    if (!(rate > 0 && rate <= 1000)) throw InputError("--rate must be in (0, 1000]");
    if (watchers < 0 || watchers > 4096) throw InputError("--watchers must be in [0, 4096]");
    if (max_in_flight < 0 || max_in_flight > 1000)
      throw InputError("--max-in-flight must be in [0, 1000]");
    SessionPlan base;
    wire::parse_endpoint(server, base.host, base.port);
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
    base.token = token, base.device = device.empty() ? rec.device_id : device;
    if (ggx_face < 0 || ggx_face > 4096) throw InputError("--ggx must be a face in [1, 4096]");
    base.rate = rate, base.duration = duration, base.maps = maps, base.ggx_face = ggx_face;
    base.connection = connection, base.reconnect_s = reconnect_s;
    base.follow_advice = !ignore_advice;
    base.max_in_flight = max_in_flight;
    base.watchers = watchers;
    base.whole_sets = whole_sets;
    const FrameJpegs frames(std::move(jpegs), rec.camera.width, rec.camera.height,
                            base.follow_advice);

    std::vector<SessionReport> reports(static_cast<std::size_t>(sessions));
    std::vector<std::thread> threads;
    const auto start = Clock::now();
    // The same moment on the wall clock, for scripts that time events against the run
    // (bench/shaped_links.sh: when a blackout ended).
    const double started_unix_s =
        std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
    for (int s = 0; s < sessions; ++s)
      threads.emplace_back([&, s] {
        SessionPlan plan = base;
        plan.phase = spread ? double(s) / sessions : 0.0;
        plan.first_frame = spread ? std::size_t(s) * usable.size() / std::size_t(sessions) : 0;
        run_session(plan, rec, frames, usable, start, reports[std::size_t(s)]);
      });
    for (auto& t : threads) t.join();

    nlohmann::json j = report_json(reports, phases, rate, duration);
    j["started_unix_s"] = started_unix_s;
    if (!json_path.empty()) write_file_atomically(json_path, j.dump(2) + "\n");
    if (!trace_path.empty()) write_file_atomically(trace_path, trace_csv(reports));
    print_summary(j);
    return j["failed"].get<int>() ? 1 : 0;
  } catch (const InputError& e) {
    std::fprintf(stderr, "arlight-load: bad input: %s\n", e.what());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "arlight-load: %s\n", e.what());
    return 1;
  }
}
