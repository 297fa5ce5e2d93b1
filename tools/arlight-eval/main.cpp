// arlight-eval: scores a client's composites of a simulated recording against the references
// arlight-sim --object rendered for it (tools/README.md; issue 18, tutorial §8).
#include <CLI/CLI.hpp>
#include <cstdio>
#include <exception>
#include <nlohmann/json.hpp>

#include "arlight/atomic_file.hpp"
#include "arlight/error.hpp"
#include "arlight/eval.hpp"

namespace {

nlohmann::json quality_json(const arlight::eval::MaskedQuality& q) {
  return {{"psnr_db", q.psnr_db}, {"ssim", q.ssim}, {"pixels", q.pixels}};
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "arlight-eval: PSNR and SSIM inside the object and its shadow, and the share of "
      "differences a viewer likely sees, of composited frames against a simulated recording's "
      "references (arlight-sim --object)"};
  std::string recording, frames, json_path, out;
  double ppd = 0;
  app.add_option("--recording", recording, "the simulated recording (with truth/reference/)")
      ->required();
  app.add_option("--frames", frames,
                 "the composites, NNNNNN.png per recording frame (arlight-client --out D writes "
                 "them to D/frames)")
      ->required();
  app.add_option("--json", json_path, "write the scores here");
  app.add_option("--out", out, "write each frame's visible-differences map here");
  app.add_option("--ppd", ppd,
                 "pixels per degree of the viewer (0: the camera's own, as an AR screen shows "
                 "the world)")
      ->capture_default_str();
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  try {
    namespace eval = arlight::eval;
    const eval::RecordingScore s = eval::score_recording(recording, frames, ppd, out);
    nlohmann::json j;
    j["pixels_per_degree"] = s.pixels_per_degree;
    j["object"] = quality_json(s.object);
    j["shadow"] = quality_json(s.shadow);
    j["fraction_seen"] = s.fraction_seen;
    for (const eval::FrameScore& f : s.frames)
      j["frames"].push_back({{"frame", f.frame},
                             {"object", quality_json(f.object)},
                             {"shadow", quality_json(f.shadow)},
                             {"fraction_seen", f.fraction_seen}});
    if (!json_path.empty()) arlight::write_file_atomically(json_path, j.dump(2) + "\n");
    std::printf("arlight-eval: %zu frames at %.1f pixels/degree\n", s.frames.size(),
                s.pixels_per_degree);
    std::printf("  object: PSNR %.2f dB, SSIM %.4f\n", s.object.psnr_db, s.object.ssim);
    std::printf("  shadow: PSNR %.2f dB, SSIM %.4f\n", s.shadow.psnr_db, s.shadow.ssim);
    std::printf("  differences likely seen: %.1f %% of the object and shadow\n",
                100 * s.fraction_seen);
    return 0;
  } catch (const arlight::InputError& e) {
    std::fprintf(stderr, "arlight-eval: bad input: %s\n", e.what());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "arlight-eval: error: %s\n", e.what());
    return 1;
  }
}
