#include "model_reports.hpp"

#include <tbb/info.h>

#include <algorithm>
#include <chrono>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <stdexcept>
#include <vector>

#include "arlight/common/atomic_file.hpp"
#include "arlight/common/error.hpp"
#include "arlight/render/colour.hpp"
#include "arlight/render/opencv.hpp"

namespace arlight::model_tool {

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

nlohmann::json describe_materials(const render::GltfModel& model) {
  nlohmann::json out = nlohmann::json::array();
  for (std::size_t i = 0; i < model.materials.size(); ++i) {
    const render::Material& m = model.materials[i];
    const render::MetallicRoughness& p = *m.pbr;
    nlohmann::json textures = nlohmann::json::array();
    const auto add = [&](const char* name, const auto& image) {
      if (image) textures.push_back({{"field", name}, {"width", image->width}, {"height", image->height}});
    };
    add("baseColorTexture", m.albedo);
    add("metallicRoughnessTexture", p.metallic_roughness);
    add("normalTexture", m.normal_map);
    add("occlusionTexture", p.occlusion);
    add("emissiveTexture", p.emissive_map);
    std::size_t triangles = 0;
    for (const render::MeshPart& part : model.mesh.parts)
      if (part.material == int(i)) triangles += part.index_count / 3;
    out.push_back({{"name", model.material_names[i]},
                   {"base_colour", {p.base_colour.r, p.base_colour.g, p.base_colour.b, p.base_colour.a}},
                   {"metallic", p.metallic},
                   {"roughness", p.roughness},
                   {"alpha", p.alpha_mask ? "MASK" : "OPAQUE"},
                   {"double_sided", m.double_sided},
                   {"textures", textures},
                   {"triangles", triangles}});
  }
  return out;
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

nlohmann::json light_map(const render::Mesh& mesh, const std::string& input, int size,
                         int directions, const std::string& output) {
  if (mesh.uvs.empty()) throw InputError(input + ": no UVs (TEXCOORD_0) to lay a light map over");
  const auto start = std::chrono::steady_clock::now();
  const std::vector<float> ao = render::bake_light_map(mesh, size, size, directions);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  cv::Mat grey(size, size, CV_8UC1);
  for (int y = 0; y < size; ++y)
    for (int x = 0; x < size; ++x)
      grey.at<std::uint8_t>(y, x) = cv::saturate_cast<std::uint8_t>(
          255.0f * ao[std::size_t(y) * std::size_t(size) + std::size_t(x)] + 0.5f);
  std::vector<std::uint8_t> png;
  if (!cv::imencode(".png", grey, png)) throw std::runtime_error("could not encode the PNG");
  write_file_atomically(output,
                        std::string_view(reinterpret_cast<const char*>(png.data()), png.size()));
  const std::vector<std::uint8_t> covered = render::uv_coverage(mesh, size, size);
  return {
      {"size", size},
      {"directions", directions},
      {"bake_seconds", seconds},
      {"covered", double(std::count(covered.begin(), covered.end(), 1)) / double(covered.size())}};
}

nlohmann::json colour_priors(const render::Mesh& mesh, const std::string& input,
                             const std::string& albedo) {
  render::Material m;
  m.kd = glm::vec3(1.0f);
  m.albedo = render::load_texture(albedo, true);
  if (mesh.uvs.empty()) throw InputError(input + ": no UVs, so no texel is covered");
  const std::vector<std::uint8_t> covered =
      render::uv_coverage(mesh, m.albedo->width, m.albedo->height);
  const auto priors = render::model_priors(mesh, m);
  if (!priors) throw InputError(input + ": its UVs cover no texel of " + albedo);
  const auto v3 = [](const glm::vec3& v) { return nlohmann::json::array({v.x, v.y, v.z}); };
  return {
      {"mean_lab", v3(priors->mean)},
      {"sd_lab", v3(priors->sd)},
      {"covered", double(std::count(covered.begin(), covered.end(), 1)) / double(covered.size())}};
}

}  // namespace arlight::model_tool
