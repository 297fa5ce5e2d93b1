// arlight-bench-colour: does the dissertation's colour correction (§5.6) bring a composite closer
// to the truth? (issue 17, "measure whether each helps")
//
// For each probe the reference is the bunny standing on the floor, lit by the true room's map
// set (the probe convolved, as arlightd would send it for a complete capture), composited
// camera-matched over a grey frame from four sides. Each lighting a client may have — the same
// maps, the live SH (bands 0-2, what ARCore-style clients shade with), or no room light at all
// (a neutral white light of the room's mean luminance, the room's priors measured apart: the
// dissertation's situation) — is then composited with each colour correction (none,
// brightness, contrast, match) and compared
// with the reference inside the object's mask: PSNR and SSIM (OpenCV's quality module). Two
// materials: the demo's white plastic and an orange one.
#include <CLI/CLI.hpp>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <glm/gtc/matrix_transform.hpp>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/quality.hpp>
#include <string>
#include <vector>

#include "arlight/common/atomic_file.hpp"
#include "arlight/common/error.hpp"
#include "arlight/common/hdr_io.hpp"
#include "arlight/common/image.hpp"
#include "arlight/common/resample.hpp"
#include "arlight/common/sh.hpp"
#include "arlight/lighting/lighting.hpp"
#include "arlight/render/opencv.hpp"
#include "arlight/render/render.hpp"

namespace fs = std::filesystem;
using namespace arlight;

namespace {

constexpr int kWidth = 640, kHeight = 480;
const std::vector<double> kShininess = {1, 10, 80, 1280};
constexpr render::ColourCorrection kCorrections[] = {
    render::ColourCorrection::None, render::ColourCorrection::Brightness,
    render::ColourCorrection::Contrast, render::ColourCorrection::Match};
const char* const kLightings[] = {"maps", "sh", "neutral"};

struct Score {
  double psnr = 0, ssim = 0;
  int n = 0;
  void add(double p, double s) { psnr += p, ssim += s, ++n; }
};

// PSNR (dB) and mean SSIM of `test` against `ref` over the mask's pixels (8-bit BGR).
std::pair<double, double> masked_quality(const cv::Mat& ref, const cv::Mat& test,
                                         const std::vector<std::uint8_t>& mask) {
  double se = 0;
  std::size_t count = 0;
  cv::Mat ssim_map;
  cv::quality::QualitySSIM::compute(ref, test, ssim_map);
  double ssim = 0;
  for (int y = 0; y < ref.rows; ++y)
    for (int x = 0; x < ref.cols; ++x) {
      if (!mask[std::size_t(y) * ref.cols + x]) continue;
      const cv::Vec3b a = ref.at<cv::Vec3b>(y, x), b = test.at<cv::Vec3b>(y, x);
      for (int c = 0; c < 3; ++c) se += (double(a[c]) - b[c]) * (double(a[c]) - b[c]);
      const cv::Vec4f s = ssim_map.at<cv::Vec4f>(y, x);
      ssim += (s[0] + s[1] + s[2]) / 3.0;
      ++count;
    }
  if (count == 0) throw std::runtime_error("the object is not in view");
  const double mse = std::max(se / double(3 * count), 1e-10);
  return {10.0 * std::log10(255.0 * 255.0 / mse), ssim / double(count)};
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "arlight-bench-colour: composites with and without the dissertation's colour "
      "correction against the composite under the true lighting (PSNR, SSIM in the "
      "object's mask)"};
  std::vector<std::string> probes;
  std::string model, json_path;
  app.add_option("probes", probes, "HDR probes (the rooms)")->required();
  app.add_option("--model", model, "glTF model")->required();
  app.add_option("--json", json_path, "write the table here");
  CLI11_PARSE(app, argc, argv);
  try {
    render::GlContext gl = render::GlContext::headless();
    render::Renderer r(kWidth, kHeight);
    const render::Mesh mesh = render::load_gltf(model);
    const render::GpuMesh gpu(mesh);
    const glm::mat4 model_matrix = render::standing_on_marker(mesh.bounds, 0.3f);
    // The marker's frame (+Z up) in the world's (+Y up).
    r.set_world_from_scene(
        glm::dmat3(glm::dvec3(1, 0, 0), glm::dvec3(0, 0, -1), glm::dvec3(0, 1, 0)));
    const CameraIntrinsics k = CameraIntrinsics::from_fov(kWidth, kHeight, 60.0);
    render::Material white, orange;
    white.kd = glm::vec3(0.7f), white.ks = glm::vec3(0.3f), white.shininess = 80;
    orange.kd = glm::vec3(0.8f, 0.35f, 0.1f), orange.ks = glm::vec3(0.1f), orange.shininess = 80;
    const std::pair<const char*, render::Material> materials[] = {{"white", white},
                                                                  {"orange", orange}};

    // score[material][lighting][correction]
    std::vector<Score> scores(2 * 3 * 4);
    for (const std::string& probe : probes) {
      const EnvMap env = load_envmap(probe).env;
      const EnvLayout layout = EnvLayout::for_size(Projection::LatLong, 128);
      const EnvMap room = resample(env, layout);
      const std::vector<EnvMap> maps =
          lighting::compute_maps(room, kShininess, layout, lighting::parse_method("auto")).maps;
      const ShCoeffs sh = sh_project(room, 2);
      // The camera exposes for the room: its mean radiance lands at 18 % grey.
      const double mean = luminance(glm::vec3(sh.c[0])) * 0.5 * std::sqrt(1.0 / M_PI);
      const double exposure = 0.18 / std::max(mean, 1e-9);
      const glm::vec3 neutral{float(mean)};
      const EnvMap flat(layout, Image(layout.width(), layout.height(), neutral));
      const render::EnvironmentPriors room_priors = render::environment_priors(maps.back());
      const cv::Mat frame(kHeight, kWidth, CV_8UC3, cv::Scalar(118, 118, 118));
      for (std::size_t mi = 0; mi < 2; ++mi) {
        const render::Material& m = materials[mi].second;
        for (int view = 0; view < 4; ++view) {
          const double az = M_PI / 4 + view * M_PI / 2;
          const glm::dvec3 eye(1.1 * std::cos(az), 1.1 * std::sin(az), 0.65);
          r.set_camera(k, glm::lookAt(eye, glm::dvec3(0, 0, 0.15), glm::dvec3(0, 0, 1)));
          const auto draw = [&](render::ColourCorrection colour, cv::Mat& out) {
            r.begin_frame();
            r.draw(gpu, m, model_matrix);
            render::ToneMapping tone{render::ToneMode::CameraMatched, exposure, 1.0};
            tone.colour = colour;
            render::composite(r, frame, tone, out);
          };
          r.set_maps(kShininess, maps);
          cv::Mat reference;
          draw(render::ColourCorrection::None, reference);
          const std::vector<std::uint8_t> mask = r.read_hdr().mask;
          for (std::size_t li = 0; li < 3; ++li) {
            r.set_environment_priors(std::nullopt);
            if (li == 0) r.set_maps(kShininess, maps);
            if (li == 1) r.clear_maps(), r.set_sh(sh);
            if (li == 2) r.set_maps({1.0}, {flat}), r.set_environment_priors(room_priors);
            for (std::size_t ci = 0; ci < 4; ++ci) {
              cv::Mat out;
              draw(kCorrections[ci], out);
              const auto [psnr, ssim] = masked_quality(reference, out, mask);
              scores[(mi * 3 + li) * 4 + ci].add(psnr, ssim);
            }
          }
        }
      }
      std::printf("%s done\n", probe.c_str());
    }

    nlohmann::json table = nlohmann::json::array();
    std::printf("\n| material | lighting | colour | PSNR (dB) | SSIM |\n|---|---|---|---|---|\n");
    for (std::size_t mi = 0; mi < 2; ++mi)
      for (std::size_t li = 0; li < 3; ++li)
        for (std::size_t ci = 0; ci < 4; ++ci) {
          const Score& s = scores[(mi * 3 + li) * 4 + ci];
          const double psnr = s.psnr / s.n, ssim = s.ssim / s.n;
          const char* colour = render::colour_correction_name(kCorrections[ci]);
          if (li == 0 && ci == 0) {
            std::printf("| %s | %s | %s | (reference) | 1 |\n", materials[mi].first, kLightings[li],
                        colour);
            continue;
          }
          std::printf("| %s | %s | %s | %.1f | %.3f |\n", materials[mi].first, kLightings[li],
                      colour, psnr, ssim);
          table.push_back({{"material", materials[mi].first},
                           {"lighting", kLightings[li]},
                           {"colour", colour},
                           {"psnr_db", psnr},
                           {"ssim", ssim}});
        }
    if (!json_path.empty())
      write_file_atomically(
          json_path,
          nlohmann::json{{"probes", probes}, {"views", 4}, {"table", table}}.dump(2) + "\n");
    return 0;
  } catch (const InputError& e) {
    std::fprintf(stderr, "arlight-bench-colour: bad input: %s\n", e.what());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "arlight-bench-colour: error: %s\n", e.what());
    return 1;
  }
}
