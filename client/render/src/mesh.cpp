#include "arlight/render/mesh.hpp"

#include <algorithm>
#include <cmath>
#include <glm/geometric.hpp>
#include <glm/gtc/matrix_transform.hpp>
#include <numbers>
#include <stdexcept>

namespace arlight::render {

void compute_bounds(Mesh& mesh) {
  if (mesh.positions.empty()) {
    mesh.bounds = {};
    return;
  }
  Bounds b{mesh.positions[0], mesh.positions[0]};
  for (const glm::vec3& p : mesh.positions) b.min = glm::min(b.min, p), b.max = glm::max(b.max, p);
  mesh.bounds = b;
}

void compute_normals(Mesh& mesh) {
  std::vector<glm::vec3> n(mesh.positions.size(), glm::vec3(0.0f));
  for (std::size_t i = 0; i + 2 < mesh.indices.size(); i += 3) {
    const auto a = mesh.indices[i], b = mesh.indices[i + 1], c = mesh.indices[i + 2];
    // |cross| is twice the area: area weighting for free.
    const glm::vec3 f =
        glm::cross(mesh.positions[b] - mesh.positions[a], mesh.positions[c] - mesh.positions[a]);
    n[a] += f, n[b] += f, n[c] += f;
  }
  for (glm::vec3& v : n) {
    const float l = glm::length(v);
    v = l > 0.0f ? v / l : glm::vec3(0.0f, 1.0f, 0.0f);
  }
  mesh.normals = std::move(n);
}

namespace {

// Any unit vector perpendicular to n.
glm::vec3 perpendicular(glm::vec3 n) {
  const glm::vec3 a = std::abs(n.x) < 0.9f ? glm::vec3(1, 0, 0) : glm::vec3(0, 1, 0);
  return glm::normalize(glm::cross(a, n));
}

}  // namespace

void compute_tangents(Mesh& mesh) {
  if (mesh.uvs.size() != mesh.positions.size())
    throw std::invalid_argument("compute_tangents: the mesh needs one uv per vertex");
  std::vector<glm::vec3> du(mesh.positions.size(), glm::vec3(0.0f));  // sum of dP/du
  std::vector<glm::vec3> dv(mesh.positions.size(), glm::vec3(0.0f));  // sum of dP/dv
  for (std::size_t i = 0; i + 2 < mesh.indices.size(); i += 3) {
    const std::uint32_t v[3] = {mesh.indices[i], mesh.indices[i + 1], mesh.indices[i + 2]};
    const glm::vec3 e1 = mesh.positions[v[1]] - mesh.positions[v[0]];
    const glm::vec3 e2 = mesh.positions[v[2]] - mesh.positions[v[0]];
    const glm::vec2 t1 = mesh.uvs[v[1]] - mesh.uvs[v[0]];
    const glm::vec2 t2 = mesh.uvs[v[2]] - mesh.uvs[v[0]];
    const float r = t1.x * t2.y - t2.x * t1.y;  // twice the signed uv-space area
    if (r == 0.0f) continue;
    // dP/du and dP/dv of the triangle, weighted by its uv area |r| (so = derivative * |r|).
    const float s = r > 0.0f ? 1.0f : -1.0f;
    const glm::vec3 tu = s * (e1 * t2.y - e2 * t1.y);
    const glm::vec3 tv = s * (e2 * t1.x - e1 * t2.x);
    for (std::uint32_t k : v) du[k] += tu, dv[k] += tv;
  }
  mesh.tangents.resize(mesh.positions.size());
  for (std::size_t k = 0; k < mesh.positions.size(); ++k) {
    const glm::vec3 n = mesh.normals[k];
    glm::vec3 t = du[k] - n * glm::dot(n, du[k]);  // Gram-Schmidt
    const float l = glm::length(t);
    t = l > 1e-12f ? t / l : perpendicular(n);
    // The bitangent points up the image, i.e. along -dP/dv (uv's v grows downwards).
    const float w = glm::dot(glm::cross(n, t), -dv[k]) < 0.0f ? -1.0f : 1.0f;
    mesh.tangents[k] = glm::vec4(t, w);
  }
}

glm::mat4 standing_on_marker(const Bounds& b, float height) {
  const float s = height / std::max(b.size().y, 1e-6f);
  glm::mat4 m = glm::rotate(glm::mat4(1.0f), glm::radians(90.0f), glm::vec3(1, 0, 0));
  m = glm::scale(m, glm::vec3(s));
  return glm::translate(m, glm::vec3(-b.centre().x, -b.min.y, -b.centre().z));
}

Mesh make_sphere(float radius, int rings, int segments) {
  if (!(radius > 0.0f) || rings < 2 || segments < 3)
    throw std::invalid_argument("make_sphere: need radius > 0, rings >= 2, segments >= 3");
  constexpr float kPi = std::numbers::pi_v<float>;
  Mesh m;
  for (int i = 0; i <= rings; ++i) {
    const float v = float(i) / rings, theta = kPi * v;
    for (int j = 0; j <= segments; ++j) {
      const float u = float(j) / segments, phi = 2.0f * kPi * u;
      const glm::vec3 n(-std::sin(theta) * std::cos(phi), std::cos(theta),
                        std::sin(theta) * std::sin(phi));
      m.positions.push_back(radius * n);
      m.normals.push_back(n);
      m.uvs.emplace_back(u, v);
      // Exact dP/du direction; bitangent cross(n, t) = -dP/dv direction, so w = +1.
      m.tangents.emplace_back(std::sin(phi), 0.0f, std::cos(phi), 1.0f);
    }
  }
  const auto at = [segments](int i, int j) { return std::uint32_t(i * (segments + 1) + j); };
  for (int i = 0; i < rings; ++i)
    for (int j = 0; j < segments; ++j) {
      // Counter-clockwise seen from outside.
      if (i > 0) m.indices.insert(m.indices.end(), {at(i, j), at(i + 1, j), at(i, j + 1)});
      if (i < rings - 1)
        m.indices.insert(m.indices.end(), {at(i, j + 1), at(i + 1, j), at(i + 1, j + 1)});
    }
  compute_bounds(m);
  return m;
}

}  // namespace arlight::render
