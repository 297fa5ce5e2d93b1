// The mesh's occlusion of itself, baked with Embree (mesh.hpp, transfer.hpp): per vertex, and
// as a light map over its UVs.
#include <algorithm>
#include <glm/geometric.hpp>
#include <stdexcept>

#include "arlight/common/sh.hpp"
#include "arlight/render/mesh.hpp"
#include "arlight/render/transfer.hpp"

namespace arlight::render {

void bake_occlusion(Mesh& mesh, int directions) {
  const Occluder occluder(mesh.positions, mesh.indices);
  // Order 3: the SH-9 transfer the renderer dots with the room's SH, and the bent normal and
  // occlusion (what the hemisphere shading and older readers use).
  const Transfer t =
      bake_transfer(occluder, mesh.positions, mesh.normals, {.directions = directions, .order = 3});
  mesh.occlusion.resize(t.size());
  for (std::size_t i = 0; i < t.size(); ++i)
    mesh.occlusion[i] = glm::vec4(t.bent_normal[i], t.ao[i]);
  mesh.transfer = t.sh;

  // The floor: up-facing points of the plane under the mesh's bounds.
  constexpr int kGround = 64;
  constexpr float kReach = 3.0f;  // half-extents, as ShadowSettings::ao_reach
  if (mesh.bounds.max == mesh.bounds.min) compute_bounds(mesh);
  const Bounds& b = mesh.bounds;
  const glm::vec2 mid(0.5f * (b.min.x + b.max.x), 0.5f * (b.min.z + b.max.z));
  const float half =
      kReach * std::max({0.5f * (b.max.x - b.min.x), 0.5f * (b.max.z - b.min.z), 1e-4f});
  GroundOcclusion& g = mesh.ground;
  g.min = mid - glm::vec2(half), g.max = mid + glm::vec2(half), g.size = kGround;
  std::vector<glm::vec3> points, up(std::size_t(kGround * kGround), glm::vec3(0, 1, 0));
  for (int j = 0; j < kGround; ++j)
    for (int i = 0; i < kGround; ++i)
      points.push_back({g.min.x + (float(i) + 0.5f) / kGround * (g.max.x - g.min.x), b.min.y,
                        g.min.y + (float(j) + 0.5f) / kGround * (g.max.y - g.min.y)});
  const Transfer floor =
      bake_transfer(occluder, points, up, {.directions = directions, .order = 3});
  g.occluded.resize(floor.size());
  for (std::size_t i = 0; i < floor.size(); ++i) g.occluded[i] = 1.0f - floor.ao[i];
  // What is hidden: the open lobe's transfer minus the occluded.
  const std::vector<double> open = sh_cosine_lobe({0.0, 1.0, 0.0}, 3);
  g.hidden_transfer.resize(floor.sh.size());
  for (std::size_t i = 0; i < floor.sh.size(); ++i)
    g.hidden_transfer[i] = float(open[i % kTransferCoefficients]) - floor.sh[i];
}

std::vector<float> bake_light_map(const Mesh& mesh, int width, int height, int directions) {
  if (mesh.uvs.size() != mesh.positions.size() || mesh.uvs.empty())
    throw std::invalid_argument("bake_light_map: the mesh has no UVs to lay a light map over");
  if (width < 1 || height < 1 || std::size_t(width) * std::size_t(height) > (std::size_t(1) << 26))
    throw std::invalid_argument("bake_light_map: the light map's size must be 1 to 8192 squared");
  // The surface point and normal at each covered texel's centre.
  const std::size_t texels = std::size_t(width) * std::size_t(height);
  std::vector<int> point_of(texels, -1);
  std::vector<glm::vec3> points, normals;
  for_each_uv_texel(mesh, width, height, [&](int x, int y, std::size_t t, const glm::dvec3& b) {
    glm::dvec3 p(0.0), n(0.0);
    for (int k = 0; k < 3; ++k) {
      const std::uint32_t v = mesh.indices[t + std::size_t(k)];
      p += b[k] * glm::dvec3(mesh.positions[v]);
      n += b[k] * glm::dvec3(mesh.normals[v]);
    }
    if (!(glm::length(n) > 1e-12)) return;
    int& slot = point_of[std::size_t(y) * std::size_t(width) + std::size_t(x)];
    if (slot < 0) slot = int(points.size()), points.emplace_back(), normals.emplace_back();
    points[std::size_t(slot)] = glm::vec3(p);
    normals[std::size_t(slot)] = glm::vec3(glm::normalize(n));
  });
  const Occluder occluder(mesh.positions, mesh.indices);
  const Transfer t =
      bake_transfer(occluder, points, normals, {.directions = directions, .order = 1});
  std::vector<float> ao(texels, -1.0f);
  for (std::size_t i = 0; i < texels; ++i)
    if (point_of[i] >= 0) ao[i] = t.ao[std::size_t(point_of[i])];
  // Padding: a few rings of uncovered texels take their covered neighbours' mean.
  for (int ring = 0; ring < 4; ++ring) {
    std::vector<float> next = ao;
    for (int y = 0; y < height; ++y)
      for (int x = 0; x < width; ++x) {
        if (ao[std::size_t(y) * width + x] >= 0.0f) continue;
        float sum = 0;
        int n = 0;
        for (int dy = -1; dy <= 1; ++dy)
          for (int dx = -1; dx <= 1; ++dx) {
            const int xx = x + dx, yy = y + dy;
            if (xx < 0 || yy < 0 || xx >= width || yy >= height) continue;
            const float v = ao[std::size_t(yy) * width + xx];
            if (v >= 0.0f) sum += v, ++n;
          }
        if (n > 0) next[std::size_t(y) * width + x] = sum / float(n);
      }
    ao = std::move(next);
  }
  for (float& v : ao)
    if (v < 0.0f) v = 1.0f;
  return ao;
}

}  // namespace arlight::render
