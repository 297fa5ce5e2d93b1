// arlight-bench-guided: how soon the light is right when the user follows arlightd's proposed
// views (issue 48 §2), against the fixed path at the same turning rate. For each probe, the
// simulated phone (30 fps, 640x480, exposure advice followed) captures once along the fixed
// path and once guided (a user turning to each proposed view at no more than the fixed path's
// fastest rate); every half second the filled map's irradiance is scored against the truth's
// (thesis eq. 6.1, mean). Reported: the seconds until it is within 5 % and 2 % (and stays), the
// error at 1 / 3 / 5 / 10 / 15 s, and the StyleLight / Laval sphere protocol (si-RMSE of a
// diffuse, a matte silver and a mirror sphere; issue 48 §3) at 1, 3, 10 s and the end.
#include <CLI/CLI.hpp>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <glm/geometric.hpp>
#include <nlohmann/json.hpp>
#include <numbers>
#include <optional>
#include <string>
#include <vector>

#include "arlight/capture/capture.hpp"
#include "arlight/common/atomic_file.hpp"
#include "arlight/common/hdr_io.hpp"
#include "arlight/common/resample.hpp"
#include "arlight/eval/eval.hpp"
#include "arlight/guided/guided_capture.hpp"
#include "arlight/lighting/lighting.hpp"
#include "arlight/sim/trajectory.hpp"

namespace fs = std::filesystem;
using namespace arlight;

namespace {

constexpr double kDeg = std::numbers::pi / 180.0;
constexpr double kScoreEvery = 0.5;                           // seconds
constexpr double kSphereAt[] = {1.0, 3.0, 10.0};              // and the end
constexpr double kErrorAt[] = {1.0, 3.0, 5.0, 10.0, 15.0};   // the table's columns

struct Run {
  std::vector<double> time, error;  // the irradiance error every kScoreEvery
  std::vector<double> stated;       // and the session's light_error then
  std::vector<glm::dvec3> view, proposal;  // where the camera looked, where it was asked to
  std::vector<eval::LightingScore> spheres;  // at kSphereAt and the end
  double light_error = 0;  // what the session stated at the end (LightUncertainty::mean)
  double coverage = 0;     // of the sphere, at the end
  std::optional<EnvMap> environment;  // the captured map at the end (filled)
  double peak_rate_deg_s = 0;
  std::size_t advised_frames = 0;
};

// The first time from which the error stays within `target` (-1: never).
double seconds_to(const Run& r, double target) {
  double since = -1.0;
  for (std::size_t i = 0; i < r.error.size(); ++i) {
    if (r.error[i] > target) since = -1.0;
    else if (since < 0.0) since = r.time[i];
  }
  return since;
}

double error_at(const Run& r, double t) {
  for (std::size_t i = 0; i < r.time.size(); ++i)
    if (r.time[i] >= t - 1e-9) return r.error[i];
  return r.error.empty() ? 0.0 : r.error.back();
}

Run capture_run(const fs::path& probe, const EnvMap& truth, const EnvMap& truth_irradiance,
                const guided::GuidedCaptureOptions& options) {
  const EnvLayout out_layout = EnvLayout::for_size(Projection::AngleMap, 128);
  const double shininess[] = {1.0};
  const auto irradiance = [&](const EnvMap& env) {
    return lighting::compute_maps(resample(env, out_layout), shininess, out_layout,
                                  lighting::parse_method("auto"))
        .maps[0];
  };
  guided::GuidedCapture capture(probe, options);
  Run run;
  double next_score = kScoreEvery;
  std::size_t next_sphere = 0;
  glm::dvec3 last_view(0.0);
  double last_time = 0.0;
  while (auto step = capture.step()) {
    const double t = step->frame.time;
    const glm::dvec3 view = guided::view_direction(step->frame.orientation);
    if (t > 0.0)
      run.peak_rate_deg_s =
          std::max(run.peak_rate_deg_s,
                   std::acos(std::clamp(glm::dot(view, last_view), -1.0, 1.0)) / kDeg /
                       (t - last_time));
    last_view = view, last_time = t;
    const bool score = t + 1e-9 >= next_score;
    const bool sphere = next_sphere < std::size(kSphereAt) && t + 1e-9 >= kSphereAt[next_sphere];
    if (!score && !sphere) continue;
    const EnvMap env = capture.session().environment();
    if (score) {
      run.time.push_back(t);
      run.error.push_back(lighting::map_error(truth_irradiance, irradiance(env)).mean);
      run.stated.push_back(capture.session().uncertainty().mean());
      run.view.push_back(view);
      run.proposal.push_back(step->proposal ? step->proposal->direction : glm::dvec3(0.0));
      next_score += kScoreEvery;
    }
    if (sphere) run.spheres.push_back(eval::score_lighting(truth, env)), ++next_sphere;
  }
  run.spheres.push_back(eval::score_lighting(truth, capture.session().environment()));
  run.light_error = capture.session().uncertainty().mean();
  run.coverage = capture.session().coverage();
  run.environment = capture.session().environment();
  run.advised_frames = capture.advised_frames();
  return run;
}

nlohmann::json run_json(const Run& r) {
  nlohmann::json spheres = nlohmann::json::array();
  for (const eval::LightingScore& s : r.spheres)
    spheres.push_back({{"diffuse_si_rmse", s.diffuse.si_rmse},
                       {"matte_silver_si_rmse", s.matte_silver.si_rmse},
                       {"mirror_si_rmse", s.mirror.si_rmse},
                       {"diffuse_rmse", s.diffuse.rmse},
                       {"dominant_light_deg", s.dominant_light_deg}});
  nlohmann::json views = nlohmann::json::array(), proposals = nlohmann::json::array();
  for (std::size_t i = 0; i < r.view.size(); ++i) {
    views.push_back({r.view[i].x, r.view[i].y, r.view[i].z});
    proposals.push_back({r.proposal[i].x, r.proposal[i].y, r.proposal[i].z});
  }
  return {{"seconds_to_5", seconds_to(r, 0.05)}, {"seconds_to_2", seconds_to(r, 0.02)},
          {"time", r.time}, {"error", r.error}, {"stated", r.stated}, {"view", views},
          {"proposal", proposals}, {"spheres_at", {1.0, 3.0, 10.0, "end"}},
          {"spheres", spheres}, {"stated_light_error", r.light_error},
          {"coverage", r.coverage}, {"peak_rate_deg_s", r.peak_rate_deg_s},
          {"advised_frames", r.advised_frames}};
}

void print_row(const char* probe, const char* path, const Run& r) {
  const auto secs = [](double s) {
    char b[16];
    if (s < 0) std::snprintf(b, sizeof b, "%6s", "never");
    else std::snprintf(b, sizeof b, "%5.1fs", s);
    return std::string(b);
  };
  std::printf("%-9s %-8s %s %s ", probe, path, secs(seconds_to(r, 0.05)).c_str(),
              secs(seconds_to(r, 0.02)).c_str());
  for (double t : kErrorAt) std::printf(" %6.1f%%", 100 * error_at(r, t));
  std::printf("   stated %5.1f%%  seen %5.1f%%  peak %3.0f deg/s  %zu advised frames\n",
              100 * r.light_error, 100 * r.coverage, r.peak_rate_deg_s, r.advised_frames);
}

capture::UncertaintyOptions& base_uncertainty() {
  static capture::UncertaintyOptions options;
  return options;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"arlight-bench-guided: seconds to a right light, guided by arlightd's proposed "
               "views against the fixed path"};
  std::vector<std::string> probes;
  int frames = 450, size = 512, width = 640, height = 480;
  double fps = 30, reaction = 0.3, accel = 360;
  std::string fixed = "top-down";
  fs::path json, work;
  app.add_option("probes", probes, "probes (HDR environment maps)")->required();
  app.add_option("--frames", frames, "frames of each capture (at --fps)")->capture_default_str();
  app.add_option("--fps", fps, "frames a second")->capture_default_str();
  app.add_option("--width", width, "frame width")->capture_default_str();
  app.add_option("--height", height, "frame height")->capture_default_str();
  app.add_option("--size", size, "capture map size (arlightd's --size)")->capture_default_str();
  app.add_option("--fixed", fixed, "the fixed path: top-down (the page's old guide) or sweep")
      ->check(CLI::IsMember({"top-down", "sweep", "poles-first"}))
      ->capture_default_str();
  app.add_option("--reaction", reaction, "the guided user's reaction time (s)")
      ->capture_default_str();
  app.add_option("--accel", accel, "the guided user's turning acceleration (deg/s^2)")
      ->capture_default_str();
  capture::UncertaintyOptions& u = base_uncertainty();
  app.add_option("--travel", u.travel_deg, "the proposal's turn cost: a view this far counts half")
      ->capture_default_str();
  app.add_option("--bright-factor", u.bright_factor, "the uncertainty's bright completion")
      ->capture_default_str();
  app.add_option("--up-bright-factor", u.up_bright_factor,
                 "the uncertainty's bright completion straight up")
      ->capture_default_str();
  app.add_option("--json", json, "write the figures here");
  app.add_option("--work", work, "write each capture's final map here (PROBE_fixed.exr, "
                                  "PROBE_guided.exr: lat-long, filled)");
  CLI11_PARSE(app, argc, argv);
  try {
    guided::GuidedCaptureOptions base;
    base.camera.frames = frames, base.camera.fps = fps;
    base.camera.width = width, base.camera.height = height;
    base.camera.seed = 1;
    base.capture.layout = capture::capture_layout_for(size);
    base.capture.fill = capture::Fill::Estimate;
    base.capture.uncertainty = base_uncertainty();
    nlohmann::json report = nlohmann::json::array();
    std::printf("irradiance error (thesis eq. 6.1, mean) against the truth; %d frames at %.0f fps, "
                "%dx%d\n%-9s %-8s %6s %6s  %7s %7s %7s %7s %7s\n",
                frames, fps, width, height, "probe", "path", "to 5%", "to 2%", "1 s", "3 s",
                "5 s", "10 s", "15 s");
    std::vector<Run> fixed_runs, guided_runs;
    for (const std::string& probe : probes) {
      const std::string name = fs::path(probe).stem().string();
      const EnvMap truth = load_envmap(probe).env;
      const EnvLayout out_layout = EnvLayout::for_size(Projection::AngleMap, 128);
      const double shininess[] = {1.0};
      const EnvMap truth_irradiance =
          lighting::compute_maps(resample(truth, out_layout), shininess, out_layout,
                                 lighting::parse_method("auto"))
              .maps[0];
      guided::GuidedCaptureOptions fixed_options = base;
      fixed_options.camera.trajectory = sim::trajectory_from_name(fixed);
      const Run f = capture_run(probe, truth, truth_irradiance, fixed_options);
      // The guided user turns no faster than the fixed path does at its fastest.
      guided::GuidedCaptureOptions guided_options = base;
      guided_options.camera.guided = sim::GuidedMotionParams{
          .max_rate_deg_s = f.peak_rate_deg_s, .accel_deg_s2 = accel, .reaction_s = reaction};
      const Run g = capture_run(probe, truth, truth_irradiance, guided_options);
      print_row(name.c_str(), fixed.c_str(), f);
      print_row(name.c_str(), "guided", g);
      std::fflush(stdout);
      report.push_back({{"probe", name}, {"fixed_path", fixed}, {"fixed", run_json(f)},
                        {"guided", run_json(g)}});
      if (!work.empty()) {
        fs::create_directories(work);
        const EnvLayout latlong = EnvLayout::for_size(Projection::LatLong, 512);
        write_exr(work / (name + "_fixed.exr"), resample(*f.environment, latlong).image.view());
        write_exr(work / (name + "_guided.exr"), resample(*g.environment, latlong).image.view());
      }
      fixed_runs.push_back(f), guided_runs.push_back(g);
    }
    // The means, and the sphere protocol's.
    std::printf("\nmean over %zu probes     ", probes.size());
    for (double t : kErrorAt) std::printf(" %5.0f s", t);
    std::printf("\n");
    for (const auto& [label, runs] :
         {std::pair<const char*, const std::vector<Run>*>{"fixed", &fixed_runs},
          {"guided", &guided_runs}}) {
      std::printf("  %-22s", label);
      for (double t : kErrorAt) {
        double sum = 0.0;
        for (const Run& r : *runs) sum += error_at(r, t);
        std::printf(" %6.1f%%", 100 * sum / runs->size());
      }
      double worst5 = 0.0, worst2 = 0.0;
      int never5 = 0, never2 = 0;
      for (const Run& r : *runs) {
        const double s5 = seconds_to(r, 0.05), s2 = seconds_to(r, 0.02);
        s5 < 0 ? ++never5 : (worst5 = std::max(worst5, s5), 0);
        s2 < 0 ? ++never2 : (worst2 = std::max(worst2, s2), 0);
      }
      std::printf("   slowest to 5%%: %.1f s (%d never), to 2%%: %.1f s (%d never)\n", worst5,
                  never5, worst2, never2);
    }
    std::printf("\nthe sphere protocol (si-RMSE diffuse / matte silver / mirror), mean over the "
                "probes; StyleLight from one image: 0.11 / 0.29 / 0.55\n");
    const char* at[] = {"1 s", "3 s", "10 s", "end"};
    for (std::size_t k = 0; k < 4; ++k)
      for (const auto& [label, runs] :
           {std::pair<const char*, const std::vector<Run>*>{"fixed", &fixed_runs},
            {"guided", &guided_runs}}) {
        double d = 0, s = 0, m = 0;
        int n = 0;
        for (const Run& r : *runs)
          if (k == 3 || k + 1 < r.spheres.size()) {
            const std::size_t i = k == 3 ? r.spheres.size() - 1 : k;
            d += r.spheres[i].diffuse.si_rmse, s += r.spheres[i].matte_silver.si_rmse;
            m += r.spheres[i].mirror.si_rmse, ++n;
          }
        if (n) std::printf("  %-4s %-7s %.3f / %.3f / %.3f\n", at[k], label, d / n, s / n, m / n);
      }
    if (!json.empty()) {
      if (json.has_parent_path()) fs::create_directories(json.parent_path());
      write_file_atomically(json, report.dump(2) + "\n");
    }
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "arlight-bench-guided: %s\n", e.what());
    return 1;
  }
}
