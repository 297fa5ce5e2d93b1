// arlight-model: what a model file holds (info), a copy without Draco compression for the
// browser client, whose WebAssembly build has no Draco decoder (convert), and its radiance
// transfer baked with Embree, timed (bake). A thin shell over arlight_render's glTF reader and
// writer and arlight_common's transfer bake.
#include <tbb/info.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <string>

#include "arlight/common/atomic_file.hpp"
#include "arlight/common/error.hpp"
#include "arlight/render/colour.hpp"
#include "arlight/render/mesh.hpp"
#include "arlight/render/opencv.hpp"
#include "arlight/render/transfer.hpp"

using namespace arlight;

namespace {

nlohmann::json describe(const render::Mesh& m) {
  const auto v3 = [](const glm::vec3& v) { return nlohmann::json::array({v.x, v.y, v.z}); };
  return {{"vertices", m.vertex_count()},
          {"triangles", m.triangle_count()},
          {"uvs", !m.uvs.empty()},
          {"occlusion", !m.occlusion.empty()},
          {"transfer", !m.transfer.empty()},
          {"ground", !m.ground.empty()},
          {"bounds", {{"min", v3(m.bounds.min)}, {"max", v3(m.bounds.max)}}}};
}

// Self-shadowing of the model's own vertices (tutorial §6.1): the bake's time and what it found.
nlohmann::json bake(const render::Mesh& m, const TransferOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  const Occluder occluder(m.positions, m.indices);
  const Transfer t = bake_transfer(occluder, m.positions, m.normals, options);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  double sum = 0;
  for (const float a : t.ao) sum += a;
  return {
      {"directions", options.directions},
      {"order", options.order},
      {"threads", tbb::info::default_concurrency()},
      {"bake_seconds", seconds},
      {"ao",
       {{"mean", sum / double(t.size())}, {"min", *std::min_element(t.ao.begin(), t.ao.end())}}}};
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "arlight-model: inspect a glTF model, re-encode it without Draco for the browser "
      "client, or bake its radiance transfer"};
  TransferOptions bake_options;
  app.require_subcommand(1);
  std::string input, output, albedo;
  CLI::App* info = app.add_subcommand("info", "print the model's vertex and triangle counts and bounds (JSON)");
  info->add_option("model", input, "a glTF 2.0 file (.glb or .gltf)")->required();
  info->add_option("--albedo", albedo,
                   "the model's colour texture (sRGB): also print its colour priors, the mean "
                   "and deviation in l alpha beta over the texels its UVs cover (dissertation "
                   "§5.1.1)");
  CLI::App* convert = app.add_subcommand(
      "convert", "write the model as a plain binary glTF (.glb): one mesh, no compression");
  convert->add_option("model", input, "a glTF 2.0 file (.glb or .gltf, Draco-compressed or not)")->required();
  convert->add_option("out", output, "the .glb to write")->required();
  bool convert_bake = false;
  convert->add_flag("--bake", convert_bake,
                    "bake the model's occlusion of itself into the copy (per vertex: _OCCLUSION, "
                    "bent normal and ambient occlusion; _SH_TRANSFER_0..2, the SH-9 transfer), so "
                    "that the page, which cannot ray-cast, draws with it");
  convert->add_option("--directions", bake_options.directions, "rays per vertex for --bake")
      ->check(CLI::Range(16, 1 << 20))
      ->capture_default_str();
  CLI::App* bake_cmd = app.add_subcommand(
      "bake",
      "bake the radiance transfer of the model's vertices (ambient occlusion, bent "
      "normals, SH transfer) with Embree on all cores; print its time and occlusion (JSON)");
  bake_cmd->add_option("model", input, "a glTF 2.0 file (.glb or .gltf)")->required();
  bake_cmd->add_option("--directions", bake_options.directions, "rays per vertex")
      ->check(CLI::Range(16, 1 << 20))
      ->capture_default_str();
  bake_cmd->add_option("--order", bake_options.order, "SH order of the transfer (3: SH-9)")
      ->check(CLI::Range(1, 8))
      ->capture_default_str();
  int light_map_size = 512;
  CLI::App* light_map_cmd = app.add_subcommand(
      "lightmap",
      "bake a light map of the model's occlusion of itself over its UVs (thesis "
      "Alg. 5.2's light map, for arlight-client --light-map): an 8-bit grey PNG");
  light_map_cmd->add_option("model", input, "a glTF 2.0 file with UVs (TEXCOORD_0)")->required();
  light_map_cmd->add_option("out", output, "the .png to write")->required();
  light_map_cmd->add_option("--size", light_map_size, "the light map's width and height")
      ->check(CLI::Range(8, 8192))
      ->capture_default_str();
  light_map_cmd->add_option("--directions", bake_options.directions, "rays per texel")
      ->check(CLI::Range(16, 1 << 20))
      ->capture_default_str();
  CLI11_PARSE(app, argc, argv);
  try {
    render::Mesh mesh = render::load_gltf(input);
    if (*convert) {
      if (convert_bake) render::bake_occlusion(mesh, bake_options.directions);
      const std::vector<std::uint8_t> glb = render::encode_glb(mesh);
      write_file_atomically(output, std::string_view(reinterpret_cast<const char*>(glb.data()), glb.size()));
    }
    nlohmann::json out = describe(mesh);
    if (*light_map_cmd) {
      if (mesh.uvs.empty())
        throw InputError(input + ": no UVs (TEXCOORD_0) to lay a light map over");
      const auto start = std::chrono::steady_clock::now();
      const std::vector<float> ao =
          render::bake_light_map(mesh, light_map_size, light_map_size, bake_options.directions);
      const double seconds =
          std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      cv::Mat grey(light_map_size, light_map_size, CV_8UC1);
      for (int y = 0; y < light_map_size; ++y)
        for (int x = 0; x < light_map_size; ++x)
          grey.at<std::uint8_t>(y, x) = cv::saturate_cast<std::uint8_t>(
              255.0f * ao[std::size_t(y) * std::size_t(light_map_size) + std::size_t(x)] + 0.5f);
      std::vector<std::uint8_t> png;
      if (!cv::imencode(".png", grey, png)) throw std::runtime_error("could not encode the PNG");
      write_file_atomically(
          output, std::string_view(reinterpret_cast<const char*>(png.data()), png.size()));
      const std::vector<std::uint8_t> covered =
          render::uv_coverage(mesh, light_map_size, light_map_size);
      out["light_map"] = {{"size", light_map_size},
                          {"directions", bake_options.directions},
                          {"bake_seconds", seconds},
                          {"covered", double(std::count(covered.begin(), covered.end(), 1)) /
                                          double(covered.size())}};
    }
    if (*bake_cmd) out["bake"] = bake(mesh, bake_options);
    if (!albedo.empty()) {
      render::Material m;
      m.kd = glm::vec3(1.0f);
      m.albedo = render::load_texture(albedo, true);
      if (mesh.uvs.empty()) throw InputError(input + ": no UVs, so no texel is covered");
      const std::vector<std::uint8_t> covered =
          render::uv_coverage(mesh, m.albedo->width, m.albedo->height);
      const auto priors = render::model_priors(mesh, m);
      if (!priors) throw InputError(input + ": its UVs cover no texel of " + albedo);
      const auto v3 = [](const glm::vec3& v) { return nlohmann::json::array({v.x, v.y, v.z}); };
      out["colour_priors"] = {{"mean_lab", v3(priors->mean)},
                              {"sd_lab", v3(priors->sd)},
                              {"covered", double(std::count(covered.begin(), covered.end(), 1)) /
                                              double(covered.size())}};
    }
    std::printf("%s\n", out.dump().c_str());
  } catch (const std::exception& e) {  // InputError (a bad model), or a file that cannot be written
    std::fprintf(stderr, "arlight-model: %s\n", e.what());
    return 1;
  }
  return 0;
}
