// Radiance transfer baked by ray casting (transfer.hpp).
#include "arlight/render/transfer.hpp"

#include <embree3/rtcore.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <glm/geometric.hpp>
#include <limits>
#include <numbers>
#include <stdexcept>

#include "arlight/common/image.hpp"

namespace arlight {

struct Occluder::Impl {
  RTCDevice device = nullptr;
  RTCScene scene = nullptr;
  ~Impl() {
    if (scene) rtcReleaseScene(scene);
    if (device) rtcReleaseDevice(device);
  }
};

Occluder::Occluder(std::span<const glm::vec3> positions, std::span<const std::uint32_t> indices)
    : impl_(new Impl) {
  if (indices.size() % 3 != 0 || indices.empty()) {
    delete impl_;
    throw std::invalid_argument("Occluder: the indices are not whole triangles");
  }
  for (const std::uint32_t i : indices)
    if (i >= positions.size()) {
      delete impl_;
      throw std::invalid_argument("Occluder: a triangle index is out of range");
    }
  glm::dvec3 lo(std::numeric_limits<double>::max()), hi(-std::numeric_limits<double>::max());
  for (const glm::vec3& p : positions)
    lo = glm::min(lo, glm::dvec3(p)), hi = glm::max(hi, glm::dvec3(p));
  radius_ = 0.5 * glm::length(hi - lo);
  impl_->device = rtcNewDevice(nullptr);
  if (!impl_->device) {
    delete impl_;
    throw std::runtime_error("Occluder: Embree could not start a device");
  }
  impl_->scene = rtcNewScene(impl_->device);
  RTCGeometry g = rtcNewGeometry(impl_->device, RTC_GEOMETRY_TYPE_TRIANGLE);
  auto* v = static_cast<float*>(rtcSetNewGeometryBuffer(
      g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), positions.size()));
  for (std::size_t i = 0; i < positions.size(); ++i)
    for (int k = 0; k < 3; ++k) v[3 * i + std::size_t(k)] = positions[i][k];
  auto* t = static_cast<std::uint32_t*>(
      rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                              3 * sizeof(std::uint32_t), indices.size() / 3));
  std::copy(indices.begin(), indices.end(), t);
  rtcCommitGeometry(g);
  rtcAttachGeometry(impl_->scene, g);
  rtcReleaseGeometry(g);
  rtcCommitScene(impl_->scene);
}

Occluder::~Occluder() { delete impl_; }

bool Occluder::occluded(const glm::dvec3& origin, const glm::dvec3& dir) const {
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  RTCRay ray{};
  ray.org_x = float(origin.x), ray.org_y = float(origin.y), ray.org_z = float(origin.z);
  ray.dir_x = float(dir.x), ray.dir_y = float(dir.y), ray.dir_z = float(dir.z);
  ray.tnear = 0.0f;
  ray.tfar = std::numeric_limits<float>::infinity();
  ray.mask = 0xFFFFFFFFu;
  rtcOccluded1(impl_->scene, &context, &ray);
  return ray.tfar < 0.0f;  // Embree sets -inf on a hit
}

void Occluder::occluded(const glm::dvec3& origin, std::span<const glm::dvec3> dirs,
                        std::span<std::uint8_t> hit) const {
  if (hit.size() != dirs.size())
    throw std::invalid_argument("Occluder::occluded: one hit per direction");
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  context.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;  // one origin: the packet shares its nodes
  for (std::size_t start = 0; start < dirs.size(); start += 16) {
    const std::size_t n = std::min<std::size_t>(16, dirs.size() - start);
    RTCRay16 rays;
    int valid[16];
    for (std::size_t i = 0; i < 16; ++i) {
      const glm::dvec3& d = dirs[start + std::min(i, n - 1)];
      valid[i] = i < n ? -1 : 0;
      rays.org_x[i] = float(origin.x), rays.org_y[i] = float(origin.y),
      rays.org_z[i] = float(origin.z);
      rays.dir_x[i] = float(d.x), rays.dir_y[i] = float(d.y), rays.dir_z[i] = float(d.z);
      rays.tnear[i] = 0.0f;
      rays.tfar[i] = std::numeric_limits<float>::infinity();
      rays.time[i] = 0.0f;
      rays.mask[i] = 0xFFFFFFFFu;
      rays.id[i] = unsigned(i);
      rays.flags[i] = 0;
    }
    rtcOccluded16(valid, impl_->scene, &context, &rays);
    for (std::size_t i = 0; i < n; ++i) hit[start + i] = rays.tfar[i] < 0.0f ? 1 : 0;
  }
}

glm::dvec3 Transfer::apply(std::size_t i, const ShCoeffs& lighting) const {
  const int n = sh_count(std::min(order, lighting.order));
  const float* t = &sh[i * std::size_t(sh_count(order))];
  glm::dvec3 sum(0.0);
  for (int k = 0; k < n; ++k) sum += double(t[k]) * lighting.c[std::size_t(k)];
  return sum;
}

Transfer bake_transfer(const Occluder& occluder, std::span<const glm::vec3> points,
                       std::span<const glm::vec3> normals, const TransferOptions& options) {
  if (points.size() != normals.size())
    throw std::invalid_argument("bake_transfer: one normal per point");
  if (options.directions < 16 || options.order < 1 || options.order > 8)
    throw std::invalid_argument("bake_transfer: directions >= 16, order 1..8");
  constexpr double kPi = std::numbers::pi;
  // Directions on a Fibonacci sphere (each 4 pi / N of solid angle) and their SH basis.
  const int n_dirs = options.directions, n_sh = sh_count(options.order);
  std::vector<glm::dvec3> dirs(static_cast<std::size_t>(n_dirs));
  std::vector<double> basis(std::size_t(n_dirs) * std::size_t(n_sh));
  const double golden = kPi * (3.0 - std::sqrt(5.0));
  for (int i = 0; i < n_dirs; ++i) {
    const double y = 1.0 - (i + 0.5) * 2.0 / n_dirs, r = std::sqrt(std::max(0.0, 1.0 - y * y));
    dirs[std::size_t(i)] = {r * std::cos(golden * i), y, r * std::sin(golden * i)};
  }
  // In Morton order of their octahedral coordinates, so that a packet of 16 consecutive
  // directions is a small patch of the sphere (coherent rays share BVH nodes).
  const auto morton = [](const glm::dvec3& d) {
    const double l1 = std::abs(d.x) + std::abs(d.y) + std::abs(d.z);
    double u = d.x / l1, v = d.z / l1;
    if (d.y < 0) {
      const double u0 = u;
      u = (1.0 - std::abs(v)) * (u0 >= 0 ? 1.0 : -1.0);
      v = (1.0 - std::abs(u0)) * (v >= 0 ? 1.0 : -1.0);
    }
    const auto qu = std::uint32_t((u * 0.5 + 0.5) * 65535.0),
               qv = std::uint32_t((v * 0.5 + 0.5) * 65535.0);
    std::uint64_t code = 0;
    for (int b = 0; b < 16; ++b)
      code |= (std::uint64_t((qu >> b) & 1u) << (2 * b)) |
              (std::uint64_t((qv >> b) & 1u) << (2 * b + 1));
    return code;
  };
  std::sort(dirs.begin(), dirs.end(),
            [&](const glm::dvec3& a, const glm::dvec3& b) { return morton(a) < morton(b); });
  for (int i = 0; i < n_dirs; ++i) {
    sh_basis_all(options.order, dirs[std::size_t(i)],
                 std::span<double>(&basis[std::size_t(i) * std::size_t(n_sh)], std::size_t(n_sh)));
  }
  const double weight = 4.0 * kPi / n_dirs / kPi;  // dw / pi
  const double epsilon = 1e-4 * std::max(occluder.radius(), 1e-6);

  Transfer out;
  out.order = options.order;
  out.ao.assign(points.size(), 0.0f);
  out.bent_normal.assign(points.size(), glm::vec3(0.0f));
  out.sh.assign(points.size() * std::size_t(n_sh), 0.0f);
  tbb::parallel_for(std::size_t(0), points.size(), [&](std::size_t p) {
    const glm::dvec3 n = glm::normalize(glm::dvec3(normals[p]));
    const glm::dvec3 origin = glm::dvec3(points[p]) + epsilon * n;
    // The directions above the point's horizon, traced together.
    std::vector<int> up;
    std::vector<glm::dvec3> up_dirs;
    for (int i = 0; i < n_dirs; ++i)
      if (glm::dot(n, dirs[std::size_t(i)]) > 0)
        up.push_back(i), up_dirs.push_back(dirs[std::size_t(i)]);
    std::vector<std::uint8_t> hit(up.size());
    occluder.occluded(origin, up_dirs, hit);
    double ao = 0;
    glm::dvec3 bent(0.0);
    std::vector<double> t(std::size_t(n_sh), 0.0);
    for (std::size_t j = 0; j < up.size(); ++j) {
      if (hit[j]) continue;
      const int i = up[j];
      const glm::dvec3& w = dirs[std::size_t(i)];
      const double c = glm::dot(n, w);
      ao += c * weight;
      bent += c * w;
      const double* y = &basis[std::size_t(i) * std::size_t(n_sh)];
      for (int k = 0; k < n_sh; ++k) t[std::size_t(k)] += c * weight * y[k];
    }
    out.ao[p] = float(std::min(ao, 1.0));  // the quadrature of the whole lobe is 1 within ~1e-3
    const double len = glm::length(bent);
    out.bent_normal[p] = glm::vec3(len > 1e-12 ? bent / len : n);
    for (int k = 0; k < n_sh; ++k)
      out.sh[p * std::size_t(n_sh) + std::size_t(k)] = float(t[std::size_t(k)]);
  });
  return out;
}

ShadowReference::ShadowReference(const EnvMap& world_map, const glm::dmat3& scene_from_world,
                                 glm::dvec3 normal)
    : normal_(glm::normalize(normal)) {
  const auto table = texel_table(world_map.layout);
  for (std::size_t i = 0; i < table->size(); ++i) {
    const glm::dvec3 d = scene_from_world * glm::dvec3(table->x[i], table->y[i], table->z[i]);
    const double c = glm::dot(d, normal_);
    const float* px = world_map.image.data() + std::size_t(table->index[i]) * 3;
    const glm::dvec3 l = glm::max(glm::dvec3(px[0], px[1], px[2]), glm::dvec3(0.0));
    if (!(c > 0) || !(l.x + l.y + l.z > 0)) continue;
    dirs_.push_back(glm::normalize(d));
    weights_.push_back(l * (table->solid_angle[i] * c));
    total_ += weights_.back();
  }
}

glm::dvec3 ShadowReference::ratio_rgb(const Occluder& occluder, const glm::dvec3& point) const {
  const glm::dvec3 origin = point + 1e-5 * std::max(occluder.radius(), 1e-6) * normal_;
  std::vector<std::uint8_t> hit(dirs_.size());
  occluder.occluded(origin, dirs_, hit);
  glm::dvec3 open(0.0);
  for (std::size_t i = 0; i < dirs_.size(); ++i)
    if (!hit[i]) open += weights_[i];
  glm::dvec3 out;
  for (int c = 0; c < 3; ++c) out[c] = total_[c] > 0 ? open[c] / total_[c] : 1.0;
  return out;
}

double ShadowReference::ratio(const Occluder& occluder, const glm::dvec3& point) const {
  // Luminance is linear: the ratio of the sums' luminances.
  const double total = luminance(total_.x, total_.y, total_.z);
  if (!(total > 0)) return 1.0;
  const glm::dvec3 r = ratio_rgb(occluder, point);
  return luminance(r.x * total_.x, r.y * total_.y, r.z * total_.z) / total;
}

std::vector<double> ShadowReference::ratios(const Occluder& occluder,
                                            std::span<const glm::dvec3> points) const {
  std::vector<double> out(points.size());
  tbb::parallel_for(std::size_t(0), points.size(),
                    [&](std::size_t i) { out[i] = ratio(occluder, points[i]); });
  return out;
}

}  // namespace arlight
