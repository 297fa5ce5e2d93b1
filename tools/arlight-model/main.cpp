// arlight-model: what a model file holds (info), and a copy without Draco compression for the
// browser client, whose WebAssembly build has no Draco decoder (convert). A thin shell over
// arlight_render's glTF reader and writer.
#include <CLI/CLI.hpp>
#include <algorithm>
#include <cstdio>
#include <nlohmann/json.hpp>
#include <string>

#include "arlight/atomic_file.hpp"
#include "arlight/error.hpp"
#include "arlight/render/colour.hpp"
#include "arlight/render/mesh.hpp"
#include "arlight/render/opencv.hpp"

using namespace arlight;

namespace {

nlohmann::json describe(const render::Mesh& m) {
  const auto v3 = [](const glm::vec3& v) { return nlohmann::json::array({v.x, v.y, v.z}); };
  return {{"vertices", m.vertex_count()},
          {"triangles", m.triangle_count()},
          {"uvs", !m.uvs.empty()},
          {"bounds", {{"min", v3(m.bounds.min)}, {"max", v3(m.bounds.max)}}}};
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"arlight-model: inspect a glTF model, or re-encode it without Draco for the browser client"};
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
  CLI11_PARSE(app, argc, argv);
  try {
    const render::Mesh mesh = render::load_gltf(input);
    if (*convert) {
      const std::vector<std::uint8_t> glb = render::encode_glb(mesh);
      write_file_atomically(output, std::string_view(reinterpret_cast<const char*>(glb.data()), glb.size()));
    }
    nlohmann::json out = describe(mesh);
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
