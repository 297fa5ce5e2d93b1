// arlight-model: what a model file holds (info: geometry and materials), a copy without Draco
// compression for the browser client, whose WebAssembly build has no Draco decoder (convert),
// its radiance transfer baked with Embree, timed (bake), and arlight's textured test model
// (sample). A thin shell over arlight_render's glTF reader and
// writer and its transfer bake (model_reports.cpp).
#include <CLI/CLI.hpp>
#include <cstdio>
#include <nlohmann/json.hpp>
#include <string>

#include "arlight/common/atomic_file.hpp"
#include "arlight/common/error.hpp"
#include "arlight/render/gltf.hpp"
#include "arlight/render/sample_models.hpp"
#include "arlight/render/transfer.hpp"
#include "model_reports.hpp"

using namespace arlight;

int main(int argc, char** argv) {
  CLI::App app{
      "arlight-model: inspect a glTF model, re-encode it without Draco for the browser "
      "client, or bake its radiance transfer"};
  TransferOptions bake_options;
  app.require_subcommand(1);
  std::string input, output, albedo;
  CLI::App* info =
      app.add_subcommand("info", "print the model's vertex and triangle counts and bounds (JSON)");
  info->add_option("model", input, "a glTF 2.0 file (.glb or .gltf)")->required();
  info->add_option("--albedo", albedo,
                   "the model's colour texture (sRGB): also print its colour priors, the mean "
                   "and deviation in l alpha beta over the texels its UVs cover (dissertation "
                   "§5.1.1)");
  CLI::App* convert = app.add_subcommand(
      "convert", "write the model as a plain binary glTF (.glb): one mesh, no compression");
  convert->add_option("model", input, "a glTF 2.0 file (.glb or .gltf, Draco-compressed or not)")
      ->required();
  convert->add_option("out", output, "the .glb to write")->required();
  bool convert_bake = false;
  convert->add_flag("--bake", convert_bake,
                    "bake the model's occlusion of itself into the copy (per vertex: _OCCLUSION, "
                    "bent normal and ambient occlusion; _SH_TRANSFER_0..2, the SH-9 transfer), so "
                    "that the page, which cannot ray-cast, draws with it");
  convert->add_option("--directions", bake_options.directions, "rays per vertex for --bake")
      ->check(CLI::Range(16, 1 << 20))
      ->capture_default_str();
  int sample_texture_size = 256;
  CLI::App* sample = app.add_subcommand(
      "sample",
      "write arlight's textured glTF metallic-roughness test model (a tiled ball of gold and "
      "terracotta on a glazed plinth: base colour, metal/roughness, normal and occlusion "
      "textures; CC0) as a .glb");
  sample->add_option("out", output, "the .glb to write")->required();
  sample->add_option("--texture-size", sample_texture_size, "its textures' width and height")
      ->check(CLI::Range(16, 4096))
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
  const auto write_glb = [&](const std::vector<std::uint8_t>& glb) {
    write_file_atomically(output,
                          std::string_view(reinterpret_cast<const char*>(glb.data()), glb.size()));
  };
  try {
    if (*sample) {
      const render::GltfModel model = render::make_tiled_ball(sample_texture_size);
      write_glb(render::encode_glb(model));
      input = output;  // described as written
    }
    render::GltfModel model = render::load_gltf_model(input);
    for (const std::string& w : model.warnings) std::fprintf(stderr, "arlight-model: %s\n", w.c_str());
    render::Mesh& mesh = model.mesh;
    if (*convert) {
      if (convert_bake) render::bake_occlusion(mesh, bake_options.directions);
      write_glb(render::encode_glb(model));
    }
    nlohmann::json out = model_tool::describe(mesh);
    out["materials"] = model_tool::describe_materials(model);
    if (*light_map_cmd)
      out["light_map"] =
          model_tool::light_map(mesh, input, light_map_size, bake_options.directions, output);
    if (*bake_cmd) out["bake"] = model_tool::bake(mesh, bake_options);
    if (!albedo.empty()) out["colour_priors"] = model_tool::colour_priors(mesh, input, albedo);
    std::printf("%s\n", out.dump().c_str());
  } catch (const std::exception& e) {  // InputError (a bad model), or a file that cannot be written
    std::fprintf(stderr, "arlight-model: %s\n", e.what());
    return 1;
  }
  return 0;
}
