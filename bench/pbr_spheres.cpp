// arlight-bench-pbr: the renderer's glTF metallic-roughness (the split sum: the GGX chain, the
// DFG table, the irradiance map) against the full BRDF integrated over the room per pixel
// (issue 34 §3).
//
// For each probe and each sphere of a grid (metallic 0 / 0.5 / 1 x roughness 0.05 ... 1), one
// sphere fills the middle of a 96 x 96 view; the renderer draws it with the probe's GGX chain
// (face 256 -> 16, as arlightd streams it) and irradiance map, and sim/reference's Embree
// reference integrates the full BRDF (common/brdf.hpp) over the probe at every other pixel.
// Reported per sphere: the mean relative error (thesis eq. 6.1 over the channels, eps = 1e-4 x
// the reference's mean) where n.v >= 0.5 and < 0.5 (the split sum's known grazing error), the
// mean absolute error over the mean radiance (dark pixels beside a lamp count by their light, not
// their ratio), and PSNR with the reference's brightest pixel as the peak.
#include <CLI/CLI.hpp>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <glm/gtc/matrix_transform.hpp>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "arlight/common/atomic_file.hpp"
#include "arlight/common/camera.hpp"
#include "arlight/common/error.hpp"
#include "arlight/common/hdr_io.hpp"
#include "arlight/common/image.hpp"
#include "arlight/common/specular_lights.hpp"
#include "arlight/lighting/ggx.hpp"
#include "arlight/reference/reference.hpp"
#include "arlight/render/render.hpp"

namespace fs = std::filesystem;
using namespace arlight;

namespace {

constexpr int kSize = 96, kStride = 2;
constexpr double kDistance = 4.0;  // the unit sphere's centre from the camera
const double kMetallic[] = {0.0, 0.5, 1.0};
const glm::vec3 kBase(0.9f, 0.64f, 0.3f);  // a warm base colour: F0 and the diffuse both tinted

// The renderer's sphere tone-mapped for the picture: x / (1 + x) at an exposure that puts the
// room's mean radiance at mid grey, sRGB-encoded, as RGBA rows.
void paint_tile(const render::HdrReadback& hdr, double exposure, std::vector<std::uint8_t>& grid,
                int grid_width, int column, int row) {
  for (int y = 0; y < kSize; ++y)
    for (int x = 0; x < kSize; ++x) {
      const glm::vec3 c = hdr.radiance.at(x, y);
      std::uint8_t* out =
          &grid[4 * (std::size_t(row * kSize + y) * std::size_t(grid_width) + std::size_t(column * kSize + x))];
      for (int ch = 0; ch < 3; ++ch) {
        const double v = exposure * c[ch], t = v / (1.0 + v);
        const double srgb = t <= 0.0031308 ? 12.92 * t : 1.055 * std::pow(t, 1.0 / 2.4) - 0.055;
        out[ch] = std::uint8_t(std::clamp(std::lround(255.0 * srgb), 0L, 255L));
      }
      out[3] = 255;
    }
}

struct SphereScore {
  double metallic = 0, roughness = 0, mean = 0, grazing = 0, head_on = 0, psnr = 0;
  double weighted = 0;  // mean |error| over the mean radiance: dark pixels count by their light
  double bias = 0;      // sum (renderer - reference) over sum reference: too bright (> 0) or dark
  double grazing_bias = 0;  // the same where n.v < 0.5
  int values = 0;
};

// A traced pixel of the reference: its column and row and the full BRDF's radiance there.
using TracedPixel = std::array<float, 5>;

SphereScore score(render::Renderer& r, const render::Mesh& sphere, const render::GpuMesh& gpu,
                  const EnvMap& room, const CameraIntrinsics& k, double metallic, double roughness,
                  int samples, render::HdrReadback* picture, std::vector<TracedPixel>* traced) {
  render::Material m;
  m.pbr = render::MetallicRoughness{};
  m.pbr->base_colour = glm::vec4(kBase, 1.0f);
  m.pbr->metallic = float(metallic);
  m.pbr->roughness = float(roughness);
  r.begin_frame();
  r.draw(gpu, m, glm::mat4(1.0f));
  const render::HdrReadback hdr = r.read_hdr();
  if (picture) *picture = hdr;
  // The reference's object is the same sphere at the same place: its placement on a marker
  // undone (standing_on_marker of a sphere 2 high is rigid).
  const glm::dmat4 stand(render::standing_on_marker(sphere.bounds, 2.0f));
  const glm::dmat4 undo = glm::inverse(stand);
  reference::PlacedObject object{sphere, m, 2.0,
                                 Pose{glm::quat_cast(glm::dmat3(undo)), glm::dvec3(undo[3])}};
  reference::ReferenceOptions options;
  options.ggx_samples = samples;
  options.shadow_grid = 2;
  const reference::ReferenceScene scene(object, room, options);
  const PinholeCamera camera(k);
  const glm::dvec3 eye(0, 0, kDistance);
  struct Pixel {
    glm::vec3 got, want;
    double nv;
  };
  std::vector<Pixel> pixels;
  for (int y = 0; y < kSize; y += kStride)
    for (int x = 0; x < kSize; x += kStride) {
      if (!hdr.mask[std::size_t(y) * kSize + std::size_t(x)]) continue;
      const glm::dvec3 d = camera.unproject({double(x), double(y)});
      // The sphere's own normal at the hit (the reference's: interpolated over its triangles).
      const double along = -glm::dot(eye, d), miss = glm::dot(eye, eye) - along * along;
      if (miss > 0.97) continue;  // the silhouette's last pixels: partly background
      const auto want = scene.object_radiance(eye, d);
      if (!want) continue;
      const glm::dvec3 p = eye + (along - std::sqrt(1.0 - miss)) * d;
      pixels.push_back({hdr.radiance.at(x, y), *want, glm::dot(glm::normalize(p), -d)});
      if (traced)
        traced->push_back({float(x), float(y), float(want->x), float(want->y), float(want->z)});
    }
  double mean_ref = 0, peak = 0;
  for (const Pixel& p : pixels)
    for (int c = 0; c < 3; ++c) mean_ref += p.want[c], peak = std::max(peak, double(p.want[c]));
  mean_ref /= 3.0 * double(std::max<std::size_t>(1, pixels.size()));
  const double eps = 1e-4 * mean_ref;
  SphereScore s{metallic, roughness, 0, 0, 0, 0, 0, 0, 0, 0};
  double grazing_want = 0;
  double se = 0;
  int n_grazing = 0, n_head_on = 0;
  for (const Pixel& p : pixels)
    for (int c = 0; c < 3; ++c) {
      const double err = std::abs(double(p.got[c]) - p.want[c]) / (p.want[c] + eps);
      s.mean += err;
      ++s.values;
      se += (double(p.got[c]) - p.want[c]) * (double(p.got[c]) - p.want[c]);
      s.weighted += std::abs(double(p.got[c]) - p.want[c]);
      s.bias += double(p.got[c]) - p.want[c];
      if (p.nv < 0.5)
        s.grazing += err, ++n_grazing, s.grazing_bias += double(p.got[c]) - p.want[c],
            grazing_want += p.want[c];
      else
        s.head_on += err, ++n_head_on;
    }
  s.mean /= std::max(1, s.values);
  s.weighted /= std::max(1, s.values) * std::max(mean_ref, 1e-30);
  s.bias /= std::max(1, s.values) * std::max(mean_ref, 1e-30);
  s.grazing_bias /= std::max(grazing_want, 1e-30);
  s.grazing /= std::max(1, n_grazing);
  s.head_on /= std::max(1, n_head_on);
  s.psnr = 10.0 * std::log10(peak * peak / std::max(se / std::max(1, s.values), 1e-30));
  return s;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"arlight-bench-pbr: metallic-roughness spheres against the full BRDF"};
  std::vector<std::string> probes;
  std::string json_path, grid_path, reference_path;
  int samples = 1024, lights = kMaxSpecularLights;
  std::vector<double> roughness_values = {0.05, 0.2, 0.4, 0.6, 0.8, 1.0};
  double threshold = SpecularSplitOptions{}.threshold, floor = SpecularSplitOptions{}.floor;
  app.add_option("--probe", probes, "probe(s) (lat-long EXR)")->required();
  app.add_option("--samples", samples, "GGX samples per pixel of the reference's narrow lobes")
      ->capture_default_str();
  app.add_option("--lights", lights,
                 "small bright lights taken out of the chain's room and shaded analytically "
                 "(split_specular_lights; 0: the chain holds the whole room)")
      ->capture_default_str()->check(CLI::Range(0, kMaxSpecularLights));
  app.add_option("--threshold", threshold, "split_specular_lights' threshold (x the mean luminance)")
      ->capture_default_str();
  app.add_option("--floor", floor, "split_specular_lights' floor (x the mean luminance)")
      ->capture_default_str();
  app.add_option("--roughness", roughness_values, "the spheres' roughness values (columns)")
      ->delimiter(',')->capture_default_str()->check(CLI::Range(0.0, 1.0));
  app.add_option("--json", json_path, "write every sphere's figures here");
  app.add_option("--grid", grid_path, "write the first probe's spheres as a PNG (rows: metallic)");
  app.add_option("--reference", reference_path,
                 "write the first probe's reference pixels, the camera and the spheres as JSON "
                 "(for other renderers: bench/three_spheres.mjs)");
  CLI11_PARSE(app, argc, argv);
  try {
    render::GlContext gl = render::GlContext::headless();
    render::Renderer r(kSize, kSize);
    const CameraIntrinsics k = CameraIntrinsics::from_fov(kSize, kSize, 40.0);
    r.set_camera(k, glm::translate(glm::dmat4(1.0), glm::dvec3(0, 0, -kDistance)));
    const render::Mesh sphere = render::make_sphere(1.0f, 64, 128);
    const render::GpuMesh gpu(sphere);
    nlohmann::json out = nlohmann::json::array();
    nlohmann::json reference = {
        {"camera", {{"width", k.width}, {"height", k.height}, {"fx", k.fx}, {"fy", k.fy},
                    {"cx", k.cx}, {"cy", k.cy}, {"eye", {0.0, 0.0, kDistance}},
                    {"looking", "-Z, +Y up; pixel (x, y) looks along normalize((x - cx) / fx, "
                                "-(y - cy) / fy, -1)"}}},
        {"sphere", {{"centre", {0, 0, 0}}, {"radius", 1.0}}},
        {"base_colour", {kBase.x, kBase.y, kBase.z}},
        {"spheres", nlohmann::json::array()}};
    std::string header = "| probe | metallic |", rule = "|---|---|";
    for (const double roughness : roughness_values) {
      char cell[32];
      std::snprintf(cell, sizeof cell, " roughness %g |", roughness);
      header += cell, rule += "---|";
    }
    std::printf("%s\n%s\n", header.c_str(), rule.c_str());
    for (const std::string& probe : probes) {
      const EnvMap room = load_envmap(probe).env;  // its negative values set to 0
      const SpecularSplit split =
          split_specular_lights(room, {.threshold = threshold, .floor = floor, .max_lights = lights});
      for (const SpecularLight& l : split.lights)
        std::fprintf(stderr, "%s: light (%.3f, %.3f, %.3f), power %.4g, radius %.2f deg\n",
                     probe.c_str(), l.direction.x, l.direction.y, l.direction.z, luminance(l.power),
                     l.radius * 180.0 / 3.14159265358979);
      const lighting::GgxChain chain =
          lighting::compute_ggx_chain(split.residual, {.face = 256, .min_face = 16});
      r.set_ggx_chain(chain.maps(), chain.roughness(), split.lights);
      // The irradiance map a map set would carry (finer than the chain's face-16 last level).
      r.set_maps({1.0}, {lighting::ggx_prefilter(room, 1.0, EnvLayout::for_size(Projection::Cube, 32))});
      const std::string name = fs::path(probe).stem().string();
      const int columns = int(roughness_values.size()), rows = int(std::size(kMetallic));
      std::vector<std::uint8_t> grid(std::size_t(columns * kSize) * std::size_t(rows * kSize) * 4, 0);
      double mean_radiance = 0.0;
      {
        const TexelTable& t = *texel_table(room.layout);
        for (std::size_t e = 0; e < t.size(); ++e)
          mean_radiance += t.solid_angle[e] * room.image.data()[3 * std::size_t(t.index[e]) + 1];
        mean_radiance /= 4.0 * 3.14159265358979;
      }
      for (const double& metallic : kMetallic) {
        std::string row = "| " + name + " | " + std::to_string(metallic).substr(0, 3) + " |";
        for (const double& roughness : roughness_values) {
          render::HdrReadback picture;
          const bool keep = !reference_path.empty() && &probe == &probes.front();
          std::vector<TracedPixel> traced;
          const SphereScore s = score(r, sphere, gpu, room, k, metallic, roughness, samples,
                                      &picture, keep ? &traced : nullptr);
          std::fprintf(stderr, "%s metallic %.1f roughness %.3f: bias %+.1f %% (n.v < 0.5: %+.1f %%)\n",
                       name.c_str(), metallic, roughness, 100 * s.bias, 100 * s.grazing_bias);
          if (keep)
            reference["spheres"].push_back(
                {{"metallic", metallic}, {"roughness", roughness},
                 {"renderer", {{"mean", s.mean}, {"weighted", s.weighted}, {"psnr_db", s.psnr}}},
                 {"pixels", traced}});
          paint_tile(picture, 0.5 / std::max(mean_radiance, 1e-9), grid, columns * kSize,
                     int(&roughness - roughness_values.data()), int(&metallic - kMetallic));
          char cell[96];
          std::snprintf(cell, sizeof cell, " %.1f %% (%.1f / %.1f); %.1f %%; %.1f dB |",
                        100 * s.mean, 100 * s.head_on, 100 * s.grazing, 100 * s.weighted, s.psnr);
          row += cell;
          out.push_back({{"probe", name}, {"metallic", metallic}, {"roughness", roughness},
                         {"mean", s.mean}, {"mean_nv_above_0_5", s.head_on},
                         {"mean_nv_below_0_5", s.grazing}, {"weighted", s.weighted},
                         {"bias", s.bias}, {"bias_nv_below_0_5", s.grazing_bias},
                         {"psnr_db", s.psnr}, {"values", s.values}});
        }
        std::printf("%s\n", row.c_str());
        std::fflush(stdout);
      }
      if (!grid_path.empty() && &probe == &probes.front())
        write_png_rgba(grid_path, columns * kSize, rows * kSize, grid);
    }
    if (!json_path.empty()) write_file_atomically(json_path, out.dump(1) + "\n");
    if (!reference_path.empty()) {
      reference["probe"] = fs::path(probes.front()).stem().string();
      write_file_atomically(reference_path, reference.dump() + "\n");
    }
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "arlight-bench-pbr: %s\n", e.what());
    return 1;
  }
}
