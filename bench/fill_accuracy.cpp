// arlight-bench-fill: how right the lighting is before the sweep is done (issue 16 §1).
//
// For each probe: a simulated phone's sweep of it (arlight_sim's LiveCamera: arlight-sim's
// sensor, auto-exposure and trajectory), captured frame by frame as arlightd captures it (its
// cube layout for --size); when the coverage first reaches each --coverage level (and after the
// last frame) the captured map is filled three ways, black (--fill none), the mean of the seen
// texels (--fill mean) and the estimate (--fill estimate), and each filled map's irradiance map
// (s = 1, auto method, 128x128 angle map) is compared with the true room's (thesis eq. 6.1,
// mean error), as `arlight-maps diff` does. All three come from the same capture in the same
// run. The sweeps run with auto-exposure alone and/or with the phone following arlightd's
// exposure advice (issue 16 §4: lights no frame measured unclipped are asked for darker). The
// estimate-filled map, and its SH-9 (bands 0-2: what ARCore-style lighting holds), are also
// scored by the sphere protocol of single-image lighting estimation (arlight_eval::
// score_lighting: si-RMSE of diffuse, matte silver and mirror spheres, and the dominant light's
// angle; issue 18 §8).
#include <CLI/CLI.hpp>
#include <algorithm>
#include <array>
#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <numbers>
#include <optional>
#include <string>
#include <vector>

#include "arlight/capture/capture.hpp"
#include "arlight/capture/exposure_advice.hpp"
#include "arlight/capture/fill.hpp"
#include "arlight/capture/uncertainty.hpp"
#include "arlight/common/atomic_file.hpp"
#include "arlight/common/error.hpp"
#include "arlight/common/hdr_io.hpp"
#include "arlight/common/resample.hpp"
#include "arlight/common/sh.hpp"
#include "arlight/eval/eval.hpp"
#include "arlight/lighting/lighting.hpp"
#include "arlight/sim/live_camera.hpp"
#include "arlight/sim/trajectory.hpp"

namespace fs = std::filesystem;
using namespace arlight;

namespace {

constexpr capture::Fill kFills[] = {capture::Fill::None, capture::Fill::Mean,
                                    capture::Fill::Estimate};

// The capture's accumulators when the coverage first reached each level, and after the last
// frame.
struct Snapshot {
  double coverage = 0;
  std::size_t frames = 0;
  capture::Accumulators acc;
};

struct Sweep {
  std::vector<Snapshot> snapshots;
  std::size_t advised_frames = 0;  // frames taken at an exposure arlightd's advice asked for
};

// A simulated phone's sweep of `probe` (arlight-sim's sensor, auto-exposure and trajectory,
// rendered frame by frame), captured into arlightd's layout from JPEG frames. With `advice` the
// phone follows arlightd's exposure advice (issue 16 §4), as arlight-client's sim: source and the
// phone page do; without it, auto-exposure alone.
Sweep sweep_of(const fs::path& probe, int frames, sim::TrajectoryKind trajectory,
               const EnvLayout& layout, const std::vector<double>& levels, bool advice) {
  sim::LiveCameraOptions co;
  co.frames = frames;
  co.trajectory = trajectory;
  co.seed = 1;
  sim::LiveCamera camera(probe, co);
  capture::CaptureOptions options;
  options.layout = layout;
  options.fill = capture::Fill::None;
  capture::CaptureSession session(camera.intrinsics(), CameraResponse::srgb(), options);
  capture::ExposureAdvisor advisor;
  Sweep out;
  const auto snap = [&] {
    out.snapshots.push_back({session.coverage(), session.frames_used(), session.accumulators()});
  };
  std::size_t next_level = 0;
  while (const auto f = camera.next()) {
    const capture::FrameResult r =
        session.add_encoded(f->jpeg, {f->time, f->exposure, f->gain, f->orientation});
    const std::optional<double> asked = advisor.after_frame(r);
    if (advice && asked) camera.request_exposure(*asked);
    if (!r.used) continue;
    for (; next_level < levels.size() && session.coverage() >= levels[next_level]; ++next_level)
      snap();
  }
  snap();
  out.advised_frames = advisor.followed();
  return out;
}

// The true room's mean luminance in `zones` equal-area elevation zones (uniform in y, bottom
// to top), relative to its mean over the sphere: what a prior for the unseen ceiling or sky
// would have to know (how much brighter or darker it is than the band a sweep saw first).
std::vector<double> elevation_profile(const EnvMap& env, int zones) {
  const TexelTable& table = *texel_table(env.layout);
  std::vector<double> omega(std::size_t(zones), 0.0), light(std::size_t(zones), 0.0);
  double all = 0.0;
  for (std::size_t i = 0; i < table.size(); ++i) {
    const int z = std::min(zones - 1, int((table.y[i] + 1.0) * 0.5 * zones));
    const float* p = &env.image.data()[3 * std::size_t(table.index[i])];
    const double l = table.solid_angle[i] * luminance(p[0], p[1], p[2]);
    omega[std::size_t(z)] += table.solid_angle[i], light[std::size_t(z)] += l, all += l;
  }
  const double mean = all / (4.0 * std::numbers::pi);
  for (std::size_t z = 0; z < light.size(); ++z)
    light[z] = omega[z] > 0.0 ? light[z] / omega[z] / mean : 0.0;
  return light;
}

// Per level (and the end): the three fills' summed errors against the truth and against the
// finished capture, the sphere protocol's sums, and how many probes got there.
struct SphereSums {
  double diffuse = 0, silver = 0, mirror = 0, angle = 0, diffuse_rmse = 0;
};
// The stated uncertainty of the light (issue 48 §1) against the real error, per direction of
// the irradiance map (each texel's luminance, weighted by its solid angle): the share of
// directions whose real error the statement brackets, and the medians of both.
struct UncertaintyCheck {
  double bracketed = 0, stated_median = 0, real_median = 0, stated_mean = 0, real_mean = 0;
};

double weighted_median(std::vector<std::pair<double, double>> values) {  // (value, weight)
  std::sort(values.begin(), values.end());
  double total = 0.0;
  for (const auto& [v, w] : values) total += w;
  double below = 0.0;
  for (const auto& [v, w] : values)
    if ((below += w) >= 0.5 * total) return v;
  return values.empty() ? 0.0 : values.back().first;
}

UncertaintyCheck check_uncertainty(const capture::LightUncertainty& stated, const EnvMap& truth,
                                   const EnvMap& estimate) {
  const TexelTable& table = *texel_table(truth.layout);
  std::vector<std::pair<double, double>> real, bound;
  UncertaintyCheck out;
  double omega = 0.0;
  for (std::size_t i = 0; i < table.size(); ++i) {
    const std::size_t t = 3 * std::size_t(table.index[i]);
    const double lt = luminance(truth.image.data()[t], truth.image.data()[t + 1],
                                truth.image.data()[t + 2]);
    const double le = luminance(estimate.image.data()[t], estimate.image.data()[t + 1],
                                estimate.image.data()[t + 2]);
    if (!(lt > 0.0)) continue;
    const double e = std::abs(le - lt) / lt;
    const double u = stated.at({table.x[i], table.y[i], table.z[i]});
    const double w = table.solid_angle[i];
    real.emplace_back(e, w), bound.emplace_back(u, w);
    omega += w;
    out.bracketed += e <= u ? w : 0.0;
    out.real_mean += w * e, out.stated_mean += w * u;
  }
  if (omega > 0.0) out.bracketed /= omega, out.real_mean /= omega, out.stated_mean /= omega;
  out.real_median = weighted_median(std::move(real));
  out.stated_median = weighted_median(std::move(bound));
  return out;
}

struct Row {
  std::array<double, 3> vs_truth{}, vs_capture{};
  UncertaintyCheck uncertainty;  // sums
  std::array<SphereSums, 2> spheres{};  // the estimate-filled capture, SH-9 of it
  int reached = 0;
};

struct Settings {
  std::vector<double> levels;
  int frames = 240;
  sim::TrajectoryKind trajectory = sim::TrajectoryKind::Sweep;
  EnvLayout layout = EnvLayout::for_size(Projection::AngleMap, 512);  // set from --size
  capture::FillOptions fill;
  capture::UncertaintyOptions uncertainty;
};

// One exposure mode over every probe: a line per probe and level, then the means.
void run_mode(const std::vector<std::string>& probes, const Settings& settings, bool advice,
              nlohmann::json& report) {
  const EnvLayout out_layout = EnvLayout::for_size(Projection::AngleMap, 128);
  const double shininess[] = {1.0};
  const std::vector<double>& levels = settings.levels;
  std::vector<Row> rows(levels.size() + 1);
  const char* mode = advice ? "advice" : "auto";
  std::printf(
      "\n%s: irradiance error (thesis eq. 6.1, mean) against the truth [against the finished "
      "capture]\n%-10s %9s  %17s %17s %17s\n",
      advice ? "auto-exposure + arlightd's exposure advice" : "auto-exposure alone", "probe",
      "coverage", "black", "mean", "estimate");
  const auto irradiance = [&](const EnvMap& env) {
    return lighting::compute_maps(resample(env, out_layout), shininess, out_layout,
                                  lighting::parse_method("auto"))
        .maps[0];
  };
  const auto filled = [&](const Snapshot& snap, capture::Fill fill) {
    capture::UnseenEstimator estimator(settings.layout, fill, settings.fill);
    const capture::MeasuredTexels measured{snap.acc.weighted_radiance, snap.acc.weight};
    estimator.fit(measured);
    return estimator.filled(measured);
  };
  for (const std::string& probe : probes) {
    const std::string name = fs::path(probe).stem().string();
    const EnvMap truth_full = load_envmap(probe).env;
    const EnvMap truth_irradiance = irradiance(truth_full);
    // The horizon-first sweep's band is y in [-0.4, 0.4] (zones 3-6 of 10); above it, the cap.
    const std::vector<double> profile = elevation_profile(truth_full, 10);
    const double cap_over_band = (profile[7] + profile[8] + profile[9]) / 3.0 / profile[6];
    std::printf("%-10s truth, 10 elevation zones bottom to top / the room's mean:", name.c_str());
    for (double v : profile) std::printf(" %.2f", v);
    std::printf("  (cap above y 0.4 / the zone below it: %.2fx)\n", cap_over_band);
    const Sweep sweep =
        sweep_of(probe, settings.frames, settings.trajectory, settings.layout, levels, advice);
    const std::vector<Snapshot>& snapshots = sweep.snapshots;
    const EnvMap captured_irradiance = irradiance(filled(snapshots.back(), capture::Fill::None));
    for (std::size_t k = 0; k < snapshots.size(); ++k) {
      const Snapshot& snap = snapshots[k];
      // The row: the level this snapshot was taken at (the last one is the end).
      Row& row = rows[k + 1 == snapshots.size() ? levels.size() : k];
      nlohmann::json entry = {{"probe", name},
                              {"truth_elevation_profile", profile},
                              {"truth_cap_over_band", cap_over_band},
                              {"exposure", mode},
                              {"advised_frames", sweep.advised_frames},
                              {"coverage", snap.coverage},
                              {"frames", snap.frames}};
      std::printf("%-10s %8.1f%% ", name.c_str(), 100 * snap.coverage);
      for (std::size_t f = 0; f < 3; ++f) {
        const EnvMap e = irradiance(filled(snap, kFills[f]));
        const double t = lighting::map_error(truth_irradiance, e).mean;
        const double c = lighting::map_error(captured_irradiance, e).mean;
        const std::string fill(capture::fill_name(kFills[f]));
        entry[fill] = t;
        entry[fill + "_vs_capture"] = c;
        row.vs_truth[f] += t, row.vs_capture[f] += c;
        std::printf("  %6.1f%% [%5.1f%%]", 100 * t, 100 * c);
      }
      // The stated uncertainty of the estimate against its real error.
      {
        capture::UnseenEstimator estimator(settings.layout, capture::Fill::Estimate,
                                           settings.fill);
        estimator.fit({snap.acc.weighted_radiance, snap.acc.weight});
        const capture::LightUncertainty stated(estimator.cells(), settings.uncertainty);
        const UncertaintyCheck u = check_uncertainty(
            stated, truth_irradiance, irradiance(filled(snap, capture::Fill::Estimate)));
        entry["uncertainty"] = {{"stated_mean", stated.mean()},
                                {"bracketed", u.bracketed},
                                {"stated_median", u.stated_median},
                                {"real_median", u.real_median},
                                {"real_mean", u.real_mean}};
        row.uncertainty.bracketed += u.bracketed, row.uncertainty.stated_mean += stated.mean();
        row.uncertainty.stated_median += u.stated_median;
        row.uncertainty.real_median += u.real_median, row.uncertainty.real_mean += u.real_mean;
        std::printf("  u %5.1f%% (bracketed %5.1f%%, median %5.1f%% vs %5.1f%%)",
                    100 * stated.mean(), 100 * u.bracketed, 100 * u.stated_median,
                    100 * u.real_median);
      }
      // The sphere protocol: the estimate-filled capture, and SH-9 of it.
      const EnvMap estimate = filled(snap, capture::Fill::Estimate);
      const EnvMap sh9(settings.layout, sh_reconstruct(sh_project(estimate, 3), settings.layout));
      for (const auto& [label, env] :
           {std::pair<const char*, const EnvMap*>{"spheres", &estimate}, {"spheres_sh9", &sh9}}) {
        const eval::LightingScore ls = eval::score_lighting(truth_full, *env);
        entry[label] = {{"diffuse_si_rmse", ls.diffuse.si_rmse},
                        {"matte_silver_si_rmse", ls.matte_silver.si_rmse},
                        {"mirror_si_rmse", ls.mirror.si_rmse},
                        {"diffuse_rmse", ls.diffuse.rmse},
                        {"dominant_light_deg", ls.dominant_light_deg}};
        SphereSums& sums = row.spheres[label == std::string("spheres") ? 0 : 1];
        sums.diffuse += ls.diffuse.si_rmse, sums.silver += ls.matte_silver.si_rmse;
        sums.mirror += ls.mirror.si_rmse, sums.angle += ls.dominant_light_deg;
        sums.diffuse_rmse += ls.diffuse.rmse;
      }
      if (k + 1 == snapshots.size()) std::printf("  (%zu advised frames)", sweep.advised_frames);
      std::printf("\n");
      ++row.reached;
      report.push_back(entry);
    }
  }
  const auto label_of = [&](std::size_t r) {
    return r < levels.size() ? "~" + std::to_string(int(100 * levels[r] + 0.5)) + " %"
                             : std::string("end");
  };
  std::printf("\n%s, mean over the probes that reached each coverage:\n", mode);
  for (std::size_t r = 0; r < rows.size(); ++r) {
    if (rows[r].reached == 0) continue;
    std::printf("  %-7s (%2d) ", label_of(r).c_str(), rows[r].reached);
    for (std::size_t f = 0; f < 3; ++f)
      std::printf("  %s %5.1f%% [%5.1f%%]", std::string(capture::fill_name(kFills[f])).c_str(),
                  100 * rows[r].vs_truth[f] / rows[r].reached,
                  100 * rows[r].vs_capture[f] / rows[r].reached);
    const UncertaintyCheck& u = rows[r].uncertainty;
    const double n = rows[r].reached;
    std::printf(
        "  %-7s stated uncertainty %5.1f%% (real %5.1f%%): brackets the real error in %5.1f%% "
        "of directions; median %5.1f%% against %5.1f%% real (%.2fx)\n",
        "", 100 * u.stated_mean / n, 100 * u.real_mean / n, 100 * u.bracketed / n,
        100 * u.stated_median / n, 100 * u.real_median / n,
        u.real_median > 0 ? u.stated_median / u.real_median : 0.0);
  }
  std::printf(
      "\n%s, the sphere protocol, mean over the probes (si-RMSE of the diffuse, matte silver "
      "and mirror spheres; diffuse RMSE; the dominant light's angle):\n",
      mode);
  for (std::size_t r = 0; r < rows.size(); ++r) {
    if (rows[r].reached == 0) continue;
    for (int k = 0; k < 2; ++k) {
      const SphereSums& m = rows[r].spheres[std::size_t(k)];
      const double n = rows[r].reached;
      std::printf(
          "  %-7s %-9s diffuse %.3f  matte silver %.3f  mirror %.3f  diffuse RMSE %.3f  "
          "light %5.1f deg\n",
          label_of(r).c_str(), k == 0 ? "captured" : "SH-9", m.diffuse / n, m.silver / n,
          m.mirror / n, m.diffuse_rmse / n, m.angle / n);
    }
  }
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"arlight-bench-fill: irradiance error of partly captured rooms, three fills"};
  std::vector<std::string> probes, exposures = {"auto", "advice"};
  Settings settings;
  settings.levels = {0.2, 0.4, 0.6};
  fs::path json;
  int size = 512;
  app.add_option("probes", probes, "probes (HDR environment maps)")->required();
  app.add_option("--coverage", settings.levels, "coverage levels to stop at (and the end)")
      ->capture_default_str();
  app.add_option("--frames", settings.frames, "frames of each simulated sweep")
      ->capture_default_str();
  app.add_option("--size", size, "capture map size (arlightd's --size: its cube layout)")
      ->capture_default_str();
  app.add_option("--exposure", exposures,
                 "the sweeps: auto-exposure alone (auto), following arlightd's exposure advice "
                 "(advice), or both in one run")
      ->check(CLI::IsMember({"auto", "advice"}))
      ->capture_default_str();
  std::string trajectory = "sweep";
  app.add_option("--trajectory", trajectory,
                 "the sweep's order: horizon first (sweep), a look straight up and down first "
                 "(poles-first), or from straight up down to straight down (top-down)")
      ->check(CLI::IsMember({"sweep", "poles-first", "top-down"}))
      ->capture_default_str();
  app.add_option("--json", json, "write the figures here");
  capture::FillOptions& fill_options = settings.fill;
  app.add_option("--zones", fill_options.zones, "the estimate's elevation zones")
      ->capture_default_str();
  app.add_option("--residual-order", fill_options.residual_order,
                 "the estimate's residual SH order")
      ->capture_default_str();
  app.add_option("--ridge", fill_options.ridge, "the estimate's ridge")->capture_default_str();
  app.add_option("--trend", fill_options.trend_limit, "the estimate's trend limit")
      ->capture_default_str();
  app.add_option("--clip-quantile", fill_options.clip_quantile,
                 "the estimate's clip (a quantile of the seen luminance)")
      ->capture_default_str();
  app.add_option("--trend-zones", fill_options.trend_zones, "the estimate's trend zones")
      ->capture_default_str();
  app.add_option("--ground-albedo", fill_options.ground_albedo,
                 "the estimate's unseen ground albedo (0: continue the seen zones alone)")
      ->capture_default_str();
  capture::UncertaintyOptions& u = settings.uncertainty;
  app.add_option("--bright-factor", u.bright_factor, "the uncertainty's bright completion")
      ->capture_default_str();
  app.add_option("--up-bright-factor", u.up_bright_factor,
                 "the uncertainty's bright completion straight up")
      ->capture_default_str();
  app.add_option("--dark-factor", u.dark_factor, "the uncertainty's dark completion")
      ->capture_default_str();
  app.add_option("--reach", u.reach_deg, "the uncertainty's reach (degrees)")->capture_default_str();
  app.add_option("--near-spread", u.near_spread, "the uncertainty's spread next to seen cells")
      ->capture_default_str();
  app.add_option("--measured-error", u.measured_error, "the uncertainty of the measured part")
      ->capture_default_str();
  app.add_option("--bright-floor", u.bright_floor, "the bright completion's floor")
      ->capture_default_str();
  CLI11_PARSE(app, argc, argv);
  try {
    settings.layout = capture::capture_layout_for(size);
    settings.trajectory = sim::trajectory_from_name(trajectory);
    nlohmann::json report = nlohmann::json::array();
    for (const std::string& exposure : exposures)
      run_mode(probes, settings, exposure == "advice", report);
    if (!json.empty()) write_file_atomically(json, report.dump(2) + "\n");
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "arlight-bench-fill: %s\n", e.what());
    return 1;
  }
}
