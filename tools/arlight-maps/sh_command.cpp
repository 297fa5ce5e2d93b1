// arlight-maps sh: project a probe to SH of order N over its own texels with their exact solid
// angles (thesis Alg. 4.4/4.5; no resampling first, so the coefficients do not depend on
// --size), reconstruct it as an angle map of --size and report how close that is (eq. 2.30).
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <string>

#include "arlight/common/hdr_io.hpp"
#include "arlight/common/projection.hpp"
#include "arlight/common/resample.hpp"
#include "arlight/common/sh.hpp"
#include "commands.hpp"
#include "maps_io.hpp"

namespace arlight::maps {

namespace {

struct ShOptions {
  std::string input;
  int order = 0;
  int size = 512;
  std::string json;
  std::string out = "out/sh";
};

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

int run_sh(const ShOptions& o) {
  namespace fs = std::filesystem;
  LoadedEnvMap probe = load_envmap(o.input);
  if (!probe.info.sanitized.clean())
    std::fprintf(stderr, "arlight-maps: %s: %s\n", o.input.c_str(),
                 probe.info.sanitized.summary().c_str());

  const EnvLayout layout = EnvLayout::for_size(Projection::AngleMap, o.size);
  const EnvMap angle = resample(probe.env, layout);

  auto t0 = std::chrono::steady_clock::now();
  const ShCoeffs coeffs = sh_project(probe.env, o.order);
  const double seconds_project = seconds_since(t0);
  t0 = std::chrono::steady_clock::now();
  const Image recon = sh_reconstruct(coeffs, layout);
  const double seconds_reconstruct = seconds_since(t0);

  // Solid-angle-weighted RMS difference over the sphere (all channels), and relative to the
  // RMS of the input itself.
  const auto table = texel_table(layout);
  double err2 = 0.0, ref2 = 0.0, wsum = 0.0;
  for (std::size_t i = 0; i < table->size(); ++i) {
    const float* a = angle.image.data() + 3 * std::size_t(table->index[i]);
    const float* b = recon.data() + 3 * std::size_t(table->index[i]);
    for (int c = 0; c < 3; ++c) {
      err2 += table->solid_angle[i] * (a[c] - b[c]) * (a[c] - b[c]) / 3.0;
      ref2 += table->solid_angle[i] * a[c] * a[c] / 3.0;
    }
    wsum += table->solid_angle[i];
  }
  const double rms = std::sqrt(err2 / wsum), rel = ref2 > 0 ? std::sqrt(err2 / ref2) : 0.0;

  ImageMetadata md;
  md.projection = Projection::AngleMap;
  md.description = "SH order " + std::to_string(o.order) + " reconstruction of " + o.input;
  for (const auto& c : coeffs.c) md.sh_coefficients.push_back({float(c.x), float(c.y), float(c.z)});
  const fs::path exr = fs::path(o.out) / "reconstruction.exr";
  write_exr(exr, recon.view(), md, ExrPixel::Half);
  const PreviewOptions preview{auto_exposure_stops(angle.image.view())};
  write_png_preview(fs::path(o.out) / "reconstruction.png", recon.view(), preview);
  write_png_preview(fs::path(o.out) / "input.png", angle.image.view(), preview);

  nlohmann::json j;
  j["order"] = o.order;
  j["size"] = o.size;
  j["seconds_project"] = seconds_project;
  j["seconds_reconstruct"] = seconds_reconstruct;
  j["rms_error"] = rms;
  j["relative_rms_error"] = rel;
  j["input"] = o.input;
  j["sanitized_values"] = probe.info.sanitized.total();
  j["coefficients"] = nlohmann::json::array();
  for (const auto& c : coeffs.c) j["coefficients"].push_back({c.x, c.y, c.z});
  const fs::path json_path = o.json.empty() ? fs::path(o.out) / "sh.json" : fs::path(o.json);
  write_json(json_path, j);

  std::printf("SH order %d (%d coefficients) of %s on a %dx%d angle map\n", o.order,
              sh_count(o.order), o.input.c_str(), o.size, o.size);
  std::printf("  projection     %8.4f s\n  reconstruction %8.4f s\n", seconds_project,
              seconds_reconstruct);
  std::printf("  RMS error      %.6g (%.2f%% of the input's RMS)\n", rms, 100.0 * rel);
  std::printf("  wrote %s, %s/reconstruction.png, %s/input.png, %s\n", exr.c_str(), o.out.c_str(),
              o.out.c_str(), json_path.c_str());
  return 0;
}

}  // namespace

Runner add_sh_command(CLI::App& app) {
  auto opts = std::make_shared<ShOptions>();
  CLI::App* sub = app.add_subcommand(
      "sh", "Project a probe to spherical harmonics of order N and reconstruct it");
  sub->add_option("--input", opts->input, "HDR environment map (EXR, HDR, PFM, PNG, JPEG, WebP)")
      ->required();
  sub->add_option("--order", opts->order, "SH order N: bands 0..N-1, N^2 coefficients")
      ->required()
      ->check(CLI::Range(1, 1024));
  sub->add_option("--size", opts->size, "side of the angle map the probe is resampled to")
      ->capture_default_str()
      ->check(CLI::Range(2, 8192));
  sub->add_option("--json", opts->json, "write the JSON report here (default DIR/sh.json)");
  sub->add_option("--out", opts->out, "output folder")->capture_default_str();
  return [opts] { return run_sh(*opts); };
}

}  // namespace arlight::maps
