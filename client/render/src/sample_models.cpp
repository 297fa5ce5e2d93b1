#include "arlight/render/sample_models.hpp"

#include <algorithm>
#include <cmath>
#include <glm/common.hpp>
#include <glm/geometric.hpp>
#include <stdexcept>

#include "arlight/common/response.hpp"

namespace arlight::render {

namespace {

constexpr int kTilesAround = 8, kTilesDown = 6;
constexpr float kGroove = 0.07f;  // a groove's half width, in tiles

std::uint8_t to_u8(float v) { return std::uint8_t(std::lround(std::clamp(v, 0.0f, 1.0f) * 255.0f)); }

// The tile surface at uv: 0 in a groove's floor, rising over the groove's width to 1 on a tile.
float tile_height(float u, float v) {
  const float fu = u * kTilesAround - std::floor(u * kTilesAround),
              fv = v * kTilesDown - std::floor(v * kTilesDown);
  const float edge = std::min({fu, 1.0f - fu, fv, 1.0f - fv});
  const float t = std::clamp(edge / kGroove, 0.0f, 1.0f);
  return t * t * (3.0f - 2.0f * t);
}

}  // namespace

GltfModel make_tiled_ball(int size) {
  if (size < 16 || size > 4096) throw std::invalid_argument("make_tiled_ball: texture size 16 to 4096");
  GltfModel model;
  // The ball (radius 0.4, centre at y 0.6) and the plinth (a sphere squashed to a disc, y 0 to
  // 0.2), one mesh of two parts.
  Mesh ball = make_sphere(0.4f, 48, 96), plinth = make_sphere(0.35f, 16, 48);
  for (glm::vec3& p : ball.positions) p.y += 0.6f;
  for (std::size_t i = 0; i < plinth.positions.size(); ++i) {
    plinth.positions[i] = plinth.positions[i] * glm::vec3(1.0f, 0.2857f, 1.0f) + glm::vec3(0.0f, 0.1f, 0.0f);
    plinth.normals[i] = glm::normalize(plinth.normals[i] * glm::vec3(1.0f, 1.0f / 0.2857f, 1.0f));
  }
  Mesh& mesh = model.mesh;
  mesh = ball;
  mesh.parts.push_back({0, std::uint32_t(ball.indices.size()), 0});
  const auto base = std::uint32_t(mesh.positions.size());
  mesh.positions.insert(mesh.positions.end(), plinth.positions.begin(), plinth.positions.end());
  mesh.normals.insert(mesh.normals.end(), plinth.normals.begin(), plinth.normals.end());
  mesh.uvs.insert(mesh.uvs.end(), plinth.uvs.begin(), plinth.uvs.end());
  mesh.parts.push_back({std::uint32_t(mesh.indices.size()), std::uint32_t(plinth.indices.size()), 1});
  for (const std::uint32_t i : plinth.indices) mesh.indices.push_back(base + i);
  compute_bounds(mesh);
  compute_tangents(mesh);

  auto image = [&](int channels, bool srgb) {
    auto t = std::make_shared<TextureImage>();
    t->width = t->height = size, t->channels = channels, t->srgb = srgb;
    t->u8.resize(std::size_t(size) * size * std::size_t(channels));
    return t;
  };
  auto colour = image(3, true), metal_rough = image(3, false), normal = image(3, false),
       occlusion = image(3, false);
  const glm::vec3 gold(1.0f, 0.782f, 0.344f), terracotta(0.5f, 0.16f, 0.08f), grout(0.05f);
  const float step = 1.0f / float(size);
  const CameraResponse srgb = CameraResponse::srgb();
  for (int y = 0; y < size; ++y)
    for (int x = 0; x < size; ++x) {
      const float u = (float(x) + 0.5f) * step, v = (float(y) + 0.5f) * step;
      const int i = int(u * kTilesAround), j = int(v * kTilesDown);
      const bool metal = (i + j) % 2 == 0;
      const float h = tile_height(u, v);
      const glm::vec3 c = glm::mix(grout, metal ? gold : terracotta, h);
      const float rough = glm::mix(0.9f, metal ? 0.15f + 0.06f * float(j) : 0.6f, h);
      // The normal from the height's slope: tangent along +u, bitangent up the image (-v); the
      // grooves are 6 % of a tile deep.
      const float depth = 0.06f / float(kTilesAround);
      const float dh_du = (tile_height(u + step, v) - tile_height(u - step, v)) / (2.0f * step);
      const float dh_dv = (tile_height(u, v + step) - tile_height(u, v - step)) / (2.0f * step);
      const glm::vec3 n = glm::normalize(glm::vec3(-depth * dh_du, depth * dh_dv, 1.0f));
      const std::size_t at = (std::size_t(y) * size + std::size_t(x)) * 3;
      for (int k = 0; k < 3; ++k) {
        colour->u8[at + k] = to_u8(srgb.encode(c[k], k));
        normal->u8[at + k] = to_u8(0.5f * n[k] + 0.5f);
        occlusion->u8[at + k] = to_u8(0.35f + 0.65f * h);
      }
      metal_rough->u8[at] = 255;
      metal_rough->u8[at + 1] = to_u8(rough);
      metal_rough->u8[at + 2] = to_u8(metal ? h : 0.0f);
    }
  Material tiles;
  tiles.pbr = MetallicRoughness{};
  tiles.pbr->metallic = 1.0f, tiles.pbr->roughness = 1.0f;  // the texture's values as they are
  tiles.albedo = colour;
  tiles.pbr->metallic_roughness = metal_rough;
  tiles.normal_map = normal;
  tiles.pbr->occlusion = occlusion;
  Material glaze;
  glaze.pbr = MetallicRoughness{};
  glaze.pbr->base_colour = glm::vec4(0.9f, 0.9f, 0.86f, 1.0f);
  glaze.pbr->metallic = 0.0f, glaze.pbr->roughness = 0.15f;
  model.materials = {tiles, glaze};
  model.material_names = {"tiles", "glaze"};
  return model;
}

}  // namespace arlight::render
