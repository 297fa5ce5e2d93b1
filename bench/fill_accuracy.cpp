// arlight-bench-fill: how right the lighting is before the sweep is done (issue 16 §1).
//
// For each probe: arlight-sim's sweep of it (a recording cached under --work), captured frame
// by frame into a --size angle map; when the coverage first reaches each --coverage level (and
// after the last frame) the captured map is filled three ways, black (--fill none), the mean of the
// seen texels (--fill mean) and the estimate (--fill estimate), and each filled map's
// irradiance map (s = 1, auto method, 128x128 angle map) is compared with the true room's
// (thesis eq. 6.1, mean error), as `arlight-maps diff` does. All three come from the same
// capture in the same run. The estimate-filled map, and its SH-9 (bands 0-2: what ARCore-style
// lighting holds), are also scored by the sphere protocol of single-image lighting estimation
// (arlight_eval::score_lighting: si-RMSE of diffuse, matte silver and mirror spheres, and the
// dominant light's angle; issue 18 §8).
#include <CLI/CLI.hpp>
#include <algorithm>
#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "arlight/atomic_file.hpp"
#include "arlight/capture.hpp"
#include "arlight/capture/fill.hpp"
#include "arlight/error.hpp"
#include "arlight/eval.hpp"
#include "arlight/hdr_io.hpp"
#include "arlight/lighting.hpp"
#include "arlight/recording.hpp"
#include "arlight/resample.hpp"
#include "arlight/sh.hpp"
#include "arlight/sim.hpp"

namespace fs = std::filesystem;
using namespace arlight;

namespace {

constexpr capture::Fill kFills[] = {capture::Fill::None, capture::Fill::Mean,
                                    capture::Fill::Estimate};

// The recording of a sweep of `probe`, simulated once and kept (keyed by the simulator's own
// description of its options, so a changed simulator makes a new one).
recording::Recording sweep_of(const fs::path& probe, const fs::path& work, int frames) {
  sim::SimOptions o;
  o.env = probe;
  o.frames = frames;
  o.seed = 1;
  o.out = work / probe.stem();
  const std::string key = sim::describe(o);
  const fs::path key_file = work / (probe.stem().string() + ".key");
  std::string old;
  if (std::ifstream in(key_file); in) old.assign(std::istreambuf_iterator<char>(in), {});
  if (old != key || !fs::exists(o.out / recording::kManifestName)) {
    fs::remove_all(o.out);
    std::printf("simulating %d frames of a sweep of %s...\n", frames, probe.c_str());
    sim::simulate(o);
    write_file_atomically(key_file, key);
  }
  return recording::read_recording(o.out);
}

// The capture's accumulators when the coverage first reached each level, and after the last
// frame.
struct Snapshot {
  double coverage = 0;
  std::size_t frames = 0;
  capture::Accumulators acc;
};

std::vector<Snapshot> snapshots_of(const recording::Recording& rec, const EnvLayout& layout,
                                   const std::vector<double>& levels) {
  capture::CaptureOptions options;
  options.layout = layout;
  options.fill = capture::Fill::None;
  capture::CaptureSession session(rec.camera, CameraResponse::srgb(), options);
  std::vector<Snapshot> out;
  const auto snap = [&] {
    out.push_back({session.coverage(), session.frames_used(), session.accumulators()});
  };
  recording::FrameReader reader(rec);
  std::size_t next_level = 0;
  while (const auto item = reader.next()) {
    if (!session.add_encoded(item->jpeg, *item->frame).used) continue;
    for (; next_level < levels.size() && session.coverage() >= levels[next_level]; ++next_level)
      snap();
  }
  snap();
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"arlight-bench-fill: irradiance error of partly captured rooms, three fills"};
  std::vector<std::string> probes;
  std::vector<double> levels = {0.2, 0.4, 0.6};
  fs::path work = "out/bench/fill", json;
  int frames = 240, size = 512;
  app.add_option("probes", probes, "probes (HDR environment maps)")->required();
  app.add_option("--coverage", levels, "coverage levels to stop at (and the end)")
      ->capture_default_str();
  app.add_option("--frames", frames, "frames of each simulated sweep")->capture_default_str();
  app.add_option("--size", size, "capture map size (angle map)")->capture_default_str();
  app.add_option("--work", work, "cache of the simulated recordings")->capture_default_str();
  app.add_option("--json", json, "write the figures here");
  capture::FillOptions fill_options;
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
  CLI11_PARSE(app, argc, argv);
  try {
    const EnvLayout out_layout = EnvLayout::for_size(Projection::AngleMap, 128);
    const double shininess[] = {1.0};
    nlohmann::json report = nlohmann::json::array();
    // Per level (and the end), per fill: summed error against the truth and against the
    // finished capture (what the fill alone is to blame for), and how many probes got there.
    const std::size_t rows = levels.size() + 1;
    std::vector<std::array<double, 3>> vs_truth(rows, {0, 0, 0}), vs_capture(rows, {0, 0, 0});
    std::vector<int> reached(rows, 0);
    struct SphereSums {
      double diffuse = 0, silver = 0, mirror = 0, angle = 0, diffuse_rmse = 0;
    };
    std::vector<std::array<SphereSums, 2>> spheres(rows);  // [row][estimate, SH-9]
    std::printf(
        "irradiance error (thesis eq. 6.1, mean) against the truth [against the finished "
        "capture]\n%-10s %9s  %17s %17s %17s\n",
        "probe", "coverage", "black", "mean", "estimate");
    const EnvLayout layout = EnvLayout::for_size(Projection::AngleMap, size);
    for (const std::string& probe : probes) {
      const std::string name = fs::path(probe).stem().string();
      const EnvMap truth = resample(load_envmap(probe).env, out_layout);
      const std::vector<Snapshot> snapshots =
          snapshots_of(sweep_of(probe, work, frames), layout, levels);
      const auto irradiance = [&](const EnvMap& env) {
        return lighting::compute_maps(resample(env, out_layout), shininess, out_layout,
                                      lighting::parse_method("auto"))
            .maps[0];
      };
      const auto filled = [&](const Snapshot& snap, capture::Fill fill) {
        capture::UnseenEstimator estimator(layout, fill, fill_options);
        const capture::MeasuredTexels measured{snap.acc.weighted_radiance, snap.acc.weight};
        estimator.fit(measured);
        return estimator.filled(measured);
      };
      const EnvMap truth_irradiance = irradiance(truth);
      const EnvMap truth_full = load_envmap(probe).env;
      const EnvMap captured_irradiance = irradiance(filled(snapshots.back(), capture::Fill::None));
      for (std::size_t k = 0; k < snapshots.size(); ++k) {
        const Snapshot& snap = snapshots[k];
        // The row: the level this snapshot was taken at (the last one is the end).
        const std::size_t row = k + 1 == snapshots.size() ? levels.size() : k;
        nlohmann::json entry = {
            {"probe", name}, {"coverage", snap.coverage}, {"frames", snap.frames}};
        std::printf("%-10s %8.1f%% ", name.c_str(), 100 * snap.coverage);
        for (std::size_t f = 0; f < 3; ++f) {
          const EnvMap e = irradiance(filled(snap, kFills[f]));
          const double t = lighting::map_error(truth_irradiance, e).mean;
          const double c = lighting::map_error(captured_irradiance, e).mean;
          const std::string fill(capture::fill_name(kFills[f]));
          entry[fill] = t;
          entry[fill + "_vs_capture"] = c;
          vs_truth[row][f] += t, vs_capture[row][f] += c;
          std::printf("  %6.1f%% [%5.1f%%]", 100 * t, 100 * c);
        }
        // The sphere protocol: the estimate-filled capture, and SH-9 of it.
        const EnvMap estimate = filled(snap, capture::Fill::Estimate);
        const EnvMap sh9(layout, sh_reconstruct(sh_project(estimate, 3), layout));
        for (const auto& [label, env] :
             {std::pair<const char*, const EnvMap*>{"spheres", &estimate}, {"spheres_sh9", &sh9}}) {
          const eval::LightingScore ls = eval::score_lighting(truth_full, *env);
          entry[label] = {{"diffuse_si_rmse", ls.diffuse.si_rmse},
                          {"matte_silver_si_rmse", ls.matte_silver.si_rmse},
                          {"mirror_si_rmse", ls.mirror.si_rmse},
                          {"diffuse_rmse", ls.diffuse.rmse},
                          {"dominant_light_deg", ls.dominant_light_deg}};
          SphereSums& sums = spheres[row][label == std::string("spheres") ? 0 : 1];
          sums.diffuse += ls.diffuse.si_rmse, sums.silver += ls.matte_silver.si_rmse;
          sums.mirror += ls.mirror.si_rmse, sums.angle += ls.dominant_light_deg;
          sums.diffuse_rmse += ls.diffuse.rmse;
        }
        std::printf("\n");
        ++reached[row];
        report.push_back(entry);
      }
    }
    std::printf("\nmean over the probes that reached each coverage:\n");
    for (std::size_t r = 0; r < rows; ++r) {
      if (reached[r] == 0) continue;
      const std::string label =
          r < levels.size() ? "~" + std::to_string(int(100 * levels[r] + 0.5)) + " %" : "end";
      std::printf("  %-7s (%2d) ", label.c_str(), reached[r]);
      for (std::size_t f = 0; f < 3; ++f)
        std::printf("  %s %5.1f%% [%5.1f%%]", std::string(capture::fill_name(kFills[f])).c_str(),
                    100 * vs_truth[r][f] / reached[r], 100 * vs_capture[r][f] / reached[r]);
      std::printf("\n");
    }
    std::printf(
        "\nthe sphere protocol, mean over the probes (si-RMSE of the diffuse, matte silver and "
        "mirror spheres; diffuse RMSE; the dominant light's angle):\n");
    for (std::size_t r = 0; r < rows; ++r) {
      if (reached[r] == 0) continue;
      const std::string label =
          r < levels.size() ? "~" + std::to_string(int(100 * levels[r] + 0.5)) + " %" : "end";
      for (int k = 0; k < 2; ++k) {
        const SphereSums& m = spheres[r][std::size_t(k)];
        const double n = reached[r];
        std::printf(
            "  %-7s %-9s diffuse %.3f  matte silver %.3f  mirror %.3f  diffuse RMSE %.3f  "
            "light %5.1f deg\n",
            label.c_str(), k == 0 ? "captured" : "SH-9", m.diffuse / n, m.silver / n, m.mirror / n,
            m.diffuse_rmse / n, m.angle / n);
      }
    }
    if (!json.empty()) write_file_atomically(json, report.dump(2) + "\n");
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "arlight-bench-fill: %s\n", e.what());
    return 1;
  }
}
