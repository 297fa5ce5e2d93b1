// arlight-bench-two-phones: how much sooner a room is captured by two phones than by one (issue
// 49 §3). One simulated phone (30 fps, 640x480) follows the whole sweep; two share it: the first
// sweeps from the start (for as long as the second), the second — its sensor's heading origin
// `--heading` degrees off, its camera `--sensitivity` times as sensitive as its exposure says —
// first looks where the first phone starts (for `--meet` seconds, to be registered), then sweeps
// the second half. Both phones' frames go into one capture session as arlightd's
// (CaptureSession::add_device), in turn. Every phone's heading drifts at `--drift` deg/s (the one
// phone's too: the same gyro). Every half second the filled map is scored against the truth
// (thesis eq. 6.1, mean irradiance error) and its coverage taken: reported are the seconds to
// 95 % coverage and to an error within 5 % (and staying), one phone against two. Each phone
// follows arlightd's exposure advice (so the lights are measured unclipped).
#include <CLI/CLI.hpp>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "arlight/capture/capture.hpp"
#include "arlight/capture/exposure_advice.hpp"
#include "arlight/common/atomic_file.hpp"
#include "arlight/common/hdr_io.hpp"
#include "arlight/common/resample.hpp"
#include "arlight/lighting/lighting.hpp"
#include "arlight/sim/live_camera.hpp"

namespace fs = std::filesystem;
using namespace arlight;

namespace {

constexpr double kScoreEvery = 0.5;  // seconds

struct Run {
  std::vector<double> time, error, coverage;
  double registered_at = -1;  // when the second phone was registered (two phones only)
  double heading_deg = 0, radiance_scale = 1;  // its registration at the end
};

// The first time from which `v` stays within (below) `target`, or above it with `above`.
double seconds_to(const Run& r, const std::vector<double>& v, double target, bool above) {
  double since = -1.0;
  for (std::size_t i = 0; i < v.size(); ++i) {
    if (above ? v[i] < target : v[i] > target) since = -1.0;
    else if (since < 0.0) since = r.time[i];
  }
  return since;
}

// A second phone's frame info: its own heading origin and drift, and a camera more sensitive
// than its exposure says.
struct SecondPhone {
  double heading_deg, drift_deg_s, sensitivity;
  FrameInfo info(const sim::LiveFrame& f, double t) const {
    const double yaw = glm::radians(-heading_deg - drift_deg_s * t);
    return {t, f.exposure * sensitivity, f.gain,
            glm::normalize(glm::angleAxis(yaw, glm::dvec3(0, 1, 0)) * f.orientation)};
  }
};

class Scorer {
 public:
  explicit Scorer(const EnvMap& truth) : truth_irradiance_(irradiance(truth)) {}
  void score(const capture::CaptureSession& s, double t, Run& run) const {
    run.time.push_back(t);
    run.error.push_back(lighting::map_error(truth_irradiance_, irradiance(s.environment())).mean);
    run.coverage.push_back(s.coverage());
  }

 private:
  static EnvMap irradiance(const EnvMap& env) {
    const EnvLayout out = EnvLayout::for_size(Projection::AngleMap, 128);
    const double shininess[] = {1.0};
    return lighting::compute_maps(resample(env, out), shininess, out,
                                  lighting::parse_method("auto"))
        .maps[0];
  }
  EnvMap truth_irradiance_;
};

capture::CaptureOptions daemon_like(int size) {
  capture::CaptureOptions o;  // as arlightd's sessions (session.cpp set_camera)
  o.layout = capture::capture_layout_for(size);
  o.fill = capture::Fill::Estimate;
  o.align_every = 4;
  o.align_max_width = 160;
  return o;
}

// The first phone's frame info: the exact orientation, its heading drifting at `drift_deg_s`.
FrameInfo info_of(const sim::LiveFrame& f, double drift_deg_s) {
  const double yaw = glm::radians(drift_deg_s * f.time);
  return {f.time, f.exposure, f.gain,
          glm::normalize(glm::angleAxis(yaw, glm::dvec3(0, 1, 0)) * f.orientation)};
}

Run one_phone(const fs::path& probe, const sim::LiveCameraOptions& camera, int size,
              double drift_deg_s, const Scorer& scorer) {
  sim::LiveCamera phone(probe, camera);
  capture::CaptureSession s(phone.intrinsics(), CameraResponse::srgb(), daemon_like(size));
  capture::ExposureAdvisor advisor;
  Run run;
  double next = kScoreEvery;
  while (auto f = phone.next()) {
    if (const auto e = advisor.after_frame(s.add_encoded(f->jpeg, info_of(*f, drift_deg_s))))
      phone.request_exposure(*e);
    if (f->time + 1e-9 >= next) scorer.score(s, f->time, run), next += kScoreEvery;
  }
  return run;
}

Run two_phones(const fs::path& probe, const sim::LiveCameraOptions& camera, int size,
               double meet_s, const SecondPhone& second, const Scorer& scorer) {
  sim::LiveCamera first(probe, camera);
  // The second phone's two parts: where the first starts, then the second half of the sweep
  // (its camera run up to there unseen).
  sim::LiveCameraOptions other = camera;
  other.seed = camera.seed + 101;
  sim::LiveCamera meeting(probe, other), half(probe, other);
  const int frames = camera.frames, meet = int(std::lround(meet_s * camera.fps));
  for (int k = 0; k < frames / 2; ++k) half.next();
  capture::CaptureSession s(first.intrinsics(), CameraResponse::srgb(), daemon_like(size));
  const int device = s.add_device(half.intrinsics(), CameraResponse::srgb(), false);
  capture::ExposureAdvisor advisor, second_advisor;  // each phone its own, as arlightd gives
  Run run;
  double next = kScoreEvery;
  // Until both are done: the second meeting the first, then its half; the first sweeping on for
  // as long.
  for (int k = 0; k < meet + frames - frames / 2; ++k) {
    const double t = k / camera.fps;
    if (k < frames / 2 + meet)
      if (auto f = first.next())
        if (const auto e =
                advisor.after_frame(s.add_encoded(f->jpeg, info_of(*f, second.drift_deg_s))))
          first.request_exposure(*e);
    std::optional<sim::LiveFrame> g = k < meet ? meeting.next() : half.next();
    if (g) {
      const capture::FrameResult r = s.add_encoded(g->jpeg, second.info(*g, t), device);
      if (r.registered && run.registered_at < 0) run.registered_at = t;
      // The advice is in the map's units; the phone takes it in its own (arlightd's
      // ExposureAdvice to a contributor), which its camera reaches at 1 / sensitivity of that.
      if (const auto e = second_advisor.after_frame(r); e && r.registered)
        (k < meet ? meeting : half)
            .request_exposure(*e * s.registration(device).radiance_scale / second.sensitivity);
    }
    if (t + 1e-9 >= next) scorer.score(s, t, run), next += kScoreEvery;
  }
  const capture::DeviceRegistration r = s.registration(device);
  const glm::dvec3 f = r.offset * glm::dvec3(0, 0, -1);
  run.heading_deg = glm::degrees(std::atan2(-f.x, -f.z));
  run.radiance_scale = r.radiance_scale;
  return run;
}

std::string secs(double s) {
  char b[16];
  if (s < 0) std::snprintf(b, sizeof b, "%6s", "never");
  else std::snprintf(b, sizeof b, "%5.1fs", s);
  return b;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"arlight-bench-two-phones: seconds to a captured room, one phone against two"};
  std::vector<std::string> probes;
  int frames = 450, size = 512;
  double fps = 30, meet = 0.5;
  SecondPhone second{123.0, 1.0, 1.4};
  fs::path json;
  app.add_option("probes", probes, "probes (HDR environment maps)")->required();
  app.add_option("--frames", frames, "frames of one phone's whole sweep (at --fps)")
      ->capture_default_str();
  app.add_option("--fps", fps, "frames a second")->capture_default_str();
  app.add_option("--size", size, "capture map size (arlightd's --size)")->capture_default_str();
  app.add_option("--meet", meet, "seconds the second phone first looks where the first starts")
      ->capture_default_str();
  app.add_option("--heading", second.heading_deg, "the second phone's heading origin (degrees)")
      ->capture_default_str();
  app.add_option("--drift", second.drift_deg_s,
                 "each phone's heading drift (deg/s; the second's the other way)")
      ->capture_default_str();
  app.add_option("--sensitivity", second.sensitivity,
                 "its camera's sensitivity against what its exposure says")
      ->capture_default_str();
  app.add_option("--json", json, "write the figures here");
  CLI11_PARSE(app, argc, argv);
  try {
    sim::LiveCameraOptions camera;
    camera.frames = frames, camera.fps = fps, camera.seed = 1;
    nlohmann::json report = nlohmann::json::array();
    std::printf("%d frames a sweep at %.0f fps; the second phone %.0f deg off, drifting %.1f "
                "deg/s, %.2fx as sensitive, meeting for %.1f s\n%-9s %-11s %8s %8s %10s %8s\n",
                frames, fps, second.heading_deg, second.drift_deg_s, second.sensitivity, meet,
                "probe", "phones", "to 95%", "to 5%", "registered", "final");
    for (const std::string& probe : probes) {
      const std::string name = fs::path(probe).stem().string();
      const Scorer scorer(load_envmap(probe).env);
      const Run one = one_phone(probe, camera, size, second.drift_deg_s, scorer);
      const Run two = two_phones(probe, camera, size, meet, second, scorer);
      for (const auto& [label, r] : {std::pair<const char*, const Run*>{"one", &one}, {"two", &two}})
        std::printf("%-9s %-11s %8s %8s %10s %7.1f%%\n", name.c_str(), label,
                    secs(seconds_to(*r, r->coverage, 0.95, true)).c_str(),
                    secs(seconds_to(*r, r->error, 0.05, false)).c_str(),
                    r == &two ? secs(r->registered_at).c_str() : "", 100 * r->error.back());
      std::printf("%-9s the second phone at the end: heading %.1f deg (drifted %.1f from %.0f), "
                  "radiance scale %.3f (truth %.3f)\n",
                  name.c_str(), two.heading_deg, two.time.back() * second.drift_deg_s,
                  second.heading_deg, two.radiance_scale, second.sensitivity);
      std::fflush(stdout);
      const auto run_json = [](const Run& r) {
        return nlohmann::json{{"seconds_to_95_coverage", seconds_to(r, r.coverage, 0.95, true)},
                              {"seconds_to_5", seconds_to(r, r.error, 0.05, false)},
                              {"registered_at", r.registered_at}, {"time", r.time},
                              {"error", r.error}, {"coverage", r.coverage}};
      };
      report.push_back({{"probe", name}, {"one", run_json(one)}, {"two", run_json(two)}});
    }
    if (!json.empty()) {
      if (json.has_parent_path()) fs::create_directories(json.parent_path());
      write_file_atomically(json, report.dump(2) + "\n");
    }
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "arlight-bench-two-phones: %s\n", e.what());
    return 1;
  }
}
