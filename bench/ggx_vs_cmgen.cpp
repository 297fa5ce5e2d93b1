// arlight-bench-ggx: the GGX chain (face 256 from a probe) against Filament's cmgen --ibl-ld at
// the same size, both timed in one run and both measured against the exact prefilter
// (ggx_prefilter_exact) at the same sampled texels of every level (issue 34 §1; make bench).
#include <CLI/CLI.hpp>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <random>

#include "arlight/common/hdr_io.hpp"
#include "arlight/lighting/ggx.hpp"

using namespace arlight;
namespace fs = std::filesystem;

namespace {

struct Errors {
  double mean = 0, max = 0;
};

// Errors (thesis eqs. 6.1/6.2, every channel) of `map` at `pixels` against `exact`.
Errors errors(const EnvMap& map, const std::vector<std::uint32_t>& pixels,
              const std::vector<glm::dvec3>& exact) {
  double mean_ref = 0;
  for (const auto& v : exact) mean_ref += (v.x + v.y + v.z) / (3.0 * double(exact.size()));
  const double eps = 1e-4 * mean_ref;
  Errors e;
  for (std::size_t i = 0; i < exact.size(); ++i)
    for (int c = 0; c < 3; ++c) {
      const double ref = exact[i][c], got = map.image.data()[3 * std::size_t(pixels[i]) + std::size_t(c)];
      const double err = std::abs(got - ref) / (ref + eps);
      e.mean += err / (3.0 * double(exact.size()));
      e.max = std::max(e.max, err);
    }
  return e;
}

// cmgen's level L faces (mL_px.hdr ... mL_nz.hdr) in our cube layout. cmgen reads a lat-long
// with its azimuth origin half a turn from ours (found by trying the 48 signed axis
// permutations: only (x, y, z) -> (-x, y, -z) matches), so our direction d is its (-d.x, d.y,
// -d.z); on the cube grid that rotation maps texel centres onto texel centres.
EnvMap load_cmgen_level(const fs::path& dir, int level, int face) {
  static const char* names[6] = {"px", "nx", "py", "ny", "pz", "nz"};
  EnvMap map(EnvLayout(Projection::Cube, face, 6 * face));
  for (int f = 0; f < 6; ++f) {
    const LoadedImage img = load_image(dir / ("m" + std::to_string(level) + "_" + names[f] + ".hdr"));
    if (img.image.width() != face || img.image.height() != face)
      throw std::runtime_error("cmgen level " + std::to_string(level) + " is not " + std::to_string(face));
    for (int y = 0; y < face; ++y)
      for (int x = 0; x < face; ++x) map.image.set(x, f * face + y, img.image.at(x, y));
  }
  EnvMap ours_frame(map.layout);
  for (int y = 0; y < 6 * face; ++y)
    for (int x = 0; x < face; ++x) {
      const glm::dvec3 d = map.layout.texel_dir(x, y);
      const glm::ivec2 t = map.layout.dir_to_texel(glm::dvec3(-d.x, d.y, -d.z));
      ours_frame.image.set(x, y, map.image.at(t.x, t.y));
    }
  return ours_frame;
}

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"arlight-bench-ggx: the GGX chain against cmgen --ibl-ld, both against the exact prefilter"};
  std::string probe, json;
  int samples = 1500;
  app.add_option("--probe", probe, "lat-long probe (EXR)")->required()->check(CLI::ExistingFile);
  app.add_option("--samples", samples, "texels per level measured against the exact prefilter");
  app.add_option("--json", json, "write the table as JSON");
  CLI11_PARSE(app, argc, argv);

  const EnvMap env = load_envmap(probe).env;  // negative values clamped, as cmgen's input is
  const fs::path work = fs::temp_directory_path() / ("arlight-bench-ggx-" + std::to_string(::getpid()));
  fs::create_directories(work);
  const fs::path hdr = work / "probe.hdr";
  write_exr(work / "probe.exr", env.image.view(), {}, ExrPixel::Float);
  if (std::system(("oiiotool " + (work / "probe.exr").string() + " -o " + hdr.string() + " >/dev/null").c_str()) != 0)
    throw std::runtime_error("oiiotool could not write " + hdr.string());

  const auto t0 = std::chrono::steady_clock::now();
  const lighting::GgxChain ours = lighting::compute_ggx_chain(env, {.face = 256, .min_face = 16});
  const double ours_seconds = seconds_since(t0);
  const auto t1 = std::chrono::steady_clock::now();
  const std::string cmd = "cmgen --ibl-ld=" + (work / "out").string() + " --size=256 -f hdr " + hdr.string() + " >/dev/null 2>&1";
  if (std::system(cmd.c_str()) != 0) throw std::runtime_error("cmgen failed: " + cmd);
  const double cmgen_seconds = seconds_since(t1);

  nlohmann::json j = {{"probe", probe}, {"ours_seconds", ours_seconds}, {"cmgen_seconds", cmgen_seconds},
                      {"levels", nlohmann::json::array()}};
  std::printf("%s: ours %.3f s, cmgen %.3f s (%.1fx)\n", probe.c_str(), ours_seconds, cmgen_seconds,
              cmgen_seconds / ours_seconds);
  std::printf("| level | roughness | face | ours mean | ours max | cmgen mean | cmgen max |\n");
  for (std::size_t k = 1; k < ours.levels.size(); ++k) {
    const auto& level = ours.levels[k];
    const int face = level.map.layout.face_size();
    const EnvMap theirs = load_cmgen_level(work / "out" / "probe", int(k), face);
    const TexelTable& t = *texel_table(level.map.layout);
    std::mt19937 rng{unsigned(k)};
    std::uniform_int_distribution<std::size_t> pick(0, t.size() - 1);
    std::vector<glm::dvec3> dirs;
    std::vector<std::uint32_t> pixels;
    for (int i = 0; i < samples; ++i) {
      const std::size_t e = pick(rng);
      dirs.emplace_back(t.x[e], t.y[e], t.z[e]);
      pixels.push_back(t.index[e]);
    }
    const auto exact = lighting::ggx_prefilter_exact(env, level.roughness, dirs);
    const Errors a = errors(level.map, pixels, exact), b = errors(theirs, pixels, exact);
    std::printf("| %zu | %.3f | %d | %.3f %% | %.2f %% | %.2f %% | %.1f %% |\n", k, level.roughness, face,
                100 * a.mean, 100 * a.max, 100 * b.mean, 100 * b.max);
    j["levels"].push_back({{"level", k}, {"roughness", level.roughness}, {"face", face},
                           {"ours_mean", a.mean}, {"ours_max", a.max}, {"ours_seconds", level.seconds},
                           {"cmgen_mean", b.mean}, {"cmgen_max", b.max}});
  }
  fs::remove_all(work);
  if (!json.empty()) {
    std::FILE* f = std::fopen(json.c_str(), "w");
    if (!f) throw std::runtime_error("cannot write " + json);
    std::fputs(j.dump(2).c_str(), f);
    std::fclose(f);
  }
  return 0;
}
