#include "arlight/render/mesh.hpp"

#include <algorithm>
#include <array>
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

void for_each_uv_texel(const Mesh& mesh, int width, int height,
                       const std::function<void(int, int, std::size_t, const glm::dvec3&)>& visit) {
  if (mesh.uvs.size() != mesh.positions.size() || width < 1 || height < 1) return;
  const glm::dvec2 size(width, height);
  for (std::size_t t = 0; t + 2 < mesh.indices.size(); t += 3) {
    std::array<glm::dvec2, 3> p;  // texel space: texel (i, j) has its centre at (i + .5, j + .5)
    for (int k = 0; k < 3; ++k)
      p[std::size_t(k)] = glm::dvec2(mesh.uvs[mesh.indices[t + std::size_t(k)]]) * size;
    const double area =
        (p[1].x - p[0].x) * (p[2].y - p[0].y) - (p[2].x - p[0].x) * (p[1].y - p[0].y);
    if (area == 0.0 || !std::isfinite(area)) continue;
    const glm::dvec2 lo = glm::min(p[0], glm::min(p[1], p[2])),
                     hi = glm::max(p[0], glm::max(p[1], p[2]));
    // A triangle spanning more than a few repeats is garbage, not a texture layout.
    if (hi.x - lo.x > 4.0 * width || hi.y - lo.y > 4.0 * height) continue;
    const auto edge = [](glm::dvec2 a, glm::dvec2 b, glm::dvec2 q) {
      return (b.x - a.x) * (q.y - a.y) - (b.y - a.y) * (q.x - a.x);
    };
    const auto at = [&](int i, int j, const glm::dvec3& b) {
      visit(((i % width) + width) % width, ((j % height) + height) % height, t, b);
    };
    bool any = false;
    for (int j = int(std::floor(lo.y)); j <= int(std::floor(hi.y)); ++j)
      for (int i = int(std::floor(lo.x)); i <= int(std::floor(hi.x)); ++i) {
        const glm::dvec2 q(i + 0.5, j + 0.5);
        // e0 is twice the area opposite corner 2, e1 opposite corner 0, e2 opposite corner 1.
        const double e0 = edge(p[0], p[1], q), e1 = edge(p[1], p[2], q), e2 = edge(p[2], p[0], q);
        if (area > 0 ? e0 >= 0 && e1 >= 0 && e2 >= 0 : e0 <= 0 && e1 <= 0 && e2 <= 0) {
          at(i, j, glm::dvec3(e1, e2, e0) / area);
          any = true;
        }
      }
    if (!any)
      for (int k = 0; k < 3; ++k) {
        glm::dvec3 corner(0.0);
        corner[k] = 1.0;
        at(int(std::floor(p[std::size_t(k)].x)), int(std::floor(p[std::size_t(k)].y)), corner);
      }
  }
}

}  // namespace arlight::render
