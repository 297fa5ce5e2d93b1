// arlight-eval: how close to the truth (tools/README.md; issue 18, tutorial §8). `composite`
// scores a client's composites of a simulated recording against the references arlight-sim
// --object rendered for it; `spheres` scores an estimated lighting against the true one.
#include <CLI/CLI.hpp>
#include <cstdio>
#include <exception>
#include <nlohmann/json.hpp>

#include "arlight/common/atomic_file.hpp"
#include "arlight/common/error.hpp"
#include "arlight/common/hdr_io.hpp"
#include "arlight/eval/eval.hpp"

namespace {

nlohmann::json quality_json(const arlight::eval::MaskedQuality& q) {
  return {{"psnr_db", q.psnr_db}, {"ssim", q.ssim}, {"pixels", q.pixels}};
}

nlohmann::json sphere_json(const arlight::eval::SphereScore& s) {
  return {{"rmse", s.rmse}, {"si_rmse", s.si_rmse}};
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"arlight-eval: how close a composite, or an estimated lighting, is to the truth"};
  app.require_subcommand(1);
  CLI::App* composite = app.add_subcommand(
      "composite",
      "PSNR and SSIM inside the object and its shadow, and the share of differences a viewer "
      "likely sees, of composited frames against a simulated recording's references "
      "(arlight-sim --object)");
  std::string recording, frames, json_path, out, row;
  double ppd = 0;
  composite->add_option("--recording", recording, "the simulated recording (with truth/reference/)")
      ->required();
  composite
      ->add_option("--frames", frames,
                   "the composites, NNNNNN.png per recording frame (arlight-client --out D "
                   "writes them to D/frames)")
      ->required();
  composite->add_option("--json", json_path, "write the scores here");
  composite->add_option("--out", out, "write each frame's visible-differences map here");
  composite->add_option("--row", row,
                        "also print the scores as a Markdown table row with this label: | label | "
                        "object PSNR | object SSIM | shadow PSNR | shadow SSIM | seen |");
  composite
      ->add_option("--ppd", ppd,
                   "pixels per degree of the viewer (0: the camera's own, as an AR screen shows "
                   "the world)")
      ->capture_default_str();
  CLI::App* spheres = app.add_subcommand(
      "spheres",
      "RMSE and scale-invariant RMSE of a diffuse, a matte silver and a mirror sphere lit by an "
      "estimated lighting against the true one, and the angle between their dominant lights");
  std::string truth;
  std::vector<std::string> estimates;
  spheres->add_option("--truth", truth, "the true environment map")->required();
  spheres->add_option("--estimate", estimates, "estimated environment maps (captured, ...)")
      ->required();
  spheres->add_option("--json", json_path, "write the scores here");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  try {
    namespace eval = arlight::eval;
    nlohmann::json j;
    if (*spheres) {
      const arlight::EnvMap t = arlight::load_envmap(truth).env;
      std::printf("%-28s %17s %17s %17s %9s\n", "estimate (RMSE / si-RMSE)", "diffuse",
                  "matte silver", "mirror", "light");
      for (const std::string& e : estimates) {
        const eval::LightingScore s = eval::score_lighting(t, arlight::load_envmap(e).env);
        j.push_back({{"estimate", e},
                     {"diffuse", sphere_json(s.diffuse)},
                     {"matte_silver", sphere_json(s.matte_silver)},
                     {"mirror", sphere_json(s.mirror)},
                     {"dominant_light_deg", s.dominant_light_deg}});
        std::printf("%-28s %8.3f / %6.3f %8.3f / %6.3f %8.3f / %6.3f %8.1f°\n",
                    e.size() > 28 ? e.substr(e.size() - 28).c_str() : e.c_str(), s.diffuse.rmse,
                    s.diffuse.si_rmse, s.matte_silver.rmse, s.matte_silver.si_rmse, s.mirror.rmse,
                    s.mirror.si_rmse, s.dominant_light_deg);
      }
    } else {
      const eval::RecordingScore s = eval::score_recording(recording, frames, ppd, out);
      j["pixels_per_degree"] = s.pixels_per_degree;
      j["object"] = quality_json(s.object);
      j["shadow"] = quality_json(s.shadow);
      j["fraction_seen"] = s.fraction_seen;
      for (const eval::FrameScore& f : s.frames)
        j["frames"].push_back({{"frame", f.frame},
                               {"object", quality_json(f.object)},
                               {"shadow", quality_json(f.shadow)},
                               {"fraction_seen", f.fraction_seen}});
      std::printf("arlight-eval: %zu frames at %.1f pixels/degree\n", s.frames.size(),
                  s.pixels_per_degree);
      std::printf("  object: PSNR %.2f dB, SSIM %.4f\n", s.object.psnr_db, s.object.ssim);
      std::printf("  shadow: PSNR %.2f dB, SSIM %.4f\n", s.shadow.psnr_db, s.shadow.ssim);
      std::printf("  differences likely seen: %.1f %% of the object and shadow\n",
                  100 * s.fraction_seen);
      if (!row.empty())
        std::printf("| %s | %.2f | %.4f | %.2f | %.4f | %.1f %% |\n", row.c_str(), s.object.psnr_db,
                    s.object.ssim, s.shadow.psnr_db, s.shadow.ssim, 100 * s.fraction_seen);
    }
    if (!json_path.empty()) arlight::write_file_atomically(json_path, j.dump(2) + "\n");
    return 0;
  } catch (const arlight::InputError& e) {
    std::fprintf(stderr, "arlight-eval: bad input: %s\n", e.what());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "arlight-eval: error: %s\n", e.what());
    return 1;
  }
}
