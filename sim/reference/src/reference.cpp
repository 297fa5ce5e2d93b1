// Reference renders of a virtual object and its shadow under the true room (reference.hpp).
#include "arlight/reference/reference.hpp"

#include <embree3/rtcore.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/quaternion.hpp>
#include <limits>
#include <nlohmann/json.hpp>
#include <numbers>
#include <opencv2/imgcodecs.hpp>
#include <stdexcept>
#include <string>
#include <vector>

#include "arlight/common/atomic_file.hpp"
#include "arlight/common/brdf.hpp"
#include "arlight/common/error.hpp"
#include "arlight/common/resample.hpp"
#include "arlight/protocol/recording.hpp"
#include "arlight/render/transfer.hpp"
#include "arlight/truth/truth.hpp"

namespace arlight::reference {

namespace {

constexpr double kPi = std::numbers::pi;
// The room's directions for the diffuse and shadow sums: a 64 x 32 lat-long (5.6 degree
// texels) of the probe, each texel one direction with its radiance x solid angle.
constexpr int kDirectionsWidth = 64;
// Metallic-roughness's: 128 x 64 (2.8 degrees), summed directly for GGX lobes of alpha >=
// kWideLobe (about 12 degrees wide and more), importance-sampled below.
constexpr int kFineWidth = 128;
constexpr double kWideLobe = 0.1;

EnvMap room_for_sums(const EnvMap& room, int width = kDirectionsWidth) {
  return resample(room, EnvLayout(Projection::LatLong, width, width / 2));
}

struct Direction {
  glm::dvec3 dir;
  glm::dvec3 weighted;  // radiance x solid angle
};

std::vector<Direction> room_directions(const EnvMap& small) {
  std::vector<Direction> out;
  for (int y = 0; y < small.layout.height(); ++y)
    for (int x = 0; x < small.layout.width(); ++x) {
      const double sa = small.layout.texel_solid_angle(x, y);
      if (!(sa > 0)) continue;
      // (probes carry small negative values from lossy compression)
      const glm::dvec3 l = glm::max(glm::dvec3(small.image.at(x, y)), glm::dvec3(0.0));
      out.push_back({small.layout.texel_dir(x, y), l * sa});
    }
  return out;
}

glm::dmat4 matrix_of(const Pose& p) {
  glm::dmat4 m = glm::mat4_cast(p.orientation);
  m[3] = glm::dvec4(p.position, 1.0);
  return m;
}

// A small integer hash (for each pixel's own rotation of the stratified lobe samples).
std::uint32_t hash(std::uint32_t x) {
  x ^= x >> 16;
  x *= 0x7feb352dU;
  x ^= x >> 15;
  x *= 0x846ca68bU;
  x ^= x >> 16;
  return x;
}

// Calls fn(u, v) at the centres of a side x side grid over [0, 1)^2 (side^2 ~ samples), the grid
// turned by a shift of its own for each pixel (Cranley-Patterson rotation): stratified lobe
// samples whose pattern does not repeat from pixel to pixel. Returns side^2.
template <class Fn>
int stratified(int samples, std::uint32_t pixel_seed, Fn&& fn) {
  const int side = std::max(1, int(std::lround(std::sqrt(double(samples)))));
  const double shift_u = (hash(pixel_seed) & 0xFFFF) / 65536.0,
               shift_v = (hash(pixel_seed ^ 0x9E3779B9U) & 0xFFFF) / 65536.0;
  for (int j = 0; j < side; ++j)
    for (int i = 0; i < side; ++i)
      fn(std::fmod((i + 0.5) / side + shift_u, 1.0), std::fmod((j + 0.5) / side + shift_v, 1.0));
  return side * side;
}

// An orthonormal basis around unit n (Duff et al. 2017).
void basis(const glm::dvec3& n, glm::dvec3& t, glm::dvec3& b) {
  const double sign = std::copysign(1.0, n.z);
  const double a = -1.0 / (sign + n.z), c = n.x * n.y * a;
  t = {1.0 + sign * n.x * n.x * a, sign * c, -sign * n.x};
  b = {c, sign + n.y * n.y * a, -n.y};
}

}  // namespace

struct ReferenceScene::Impl {
  ReferenceOptions options;
  render::Material material;
  RTCDevice device = nullptr;
  RTCScene scene = nullptr;
  std::vector<glm::vec3> positions, normals;  // world frame
  std::vector<std::uint32_t> indices;
  double radius = 0, epsilon = 0;
  EnvSampler sampler;
  std::vector<Direction> directions;
  std::vector<Direction> fine;  // metallic-roughness materials' sums (kFineWidth)
  std::optional<GgxMultipleScattering> multiple_scattering;  // ... and their lobe's
  // The floor: the marker's plane through its centre, normal n, axes u, v; the shadow grid.
  glm::dvec3 floor_origin{0.0}, floor_normal{0, 1, 0}, floor_u{1, 0, 0}, floor_v{0, 0, 1};
  double grid_half = 1;
  std::vector<glm::vec3> grid;  // shadow_grid^2 ratios, RGB

  Impl(const EnvMap& room, const ReferenceOptions& o) : options(o), sampler(room) {}
  ~Impl() {
    if (scene) rtcReleaseScene(scene);
    if (device) rtcReleaseDevice(device);
  }

  bool occluded(const glm::dvec3& origin, const glm::dvec3& dir) const {
    RTCIntersectContext context;
    rtcInitIntersectContext(&context);
    RTCRay ray{};
    ray.org_x = float(origin.x), ray.org_y = float(origin.y), ray.org_z = float(origin.z);
    ray.dir_x = float(dir.x), ray.dir_y = float(dir.y), ray.dir_z = float(dir.z);
    ray.tnear = 0.0f;
    ray.tfar = std::numeric_limits<float>::infinity();
    ray.mask = 0xFFFFFFFFu;
    rtcOccluded1(scene, &context, &ray);
    return ray.tfar < 0.0f;  // Embree sets -inf on a hit
  }

  // glTF metallic-roughness at a surface point: the full BRDF (common/brdf.hpp) over the room,
  // not the split sum, with Kulla & Conty's multiple-scattering lobe (what the renderer's
  // compensation stands for). The diffuse part and wide specular lobes (alpha >= kWideLobe) are summed
  // over the room's directions (`fine`: a 128 x 64 lat-long, 2.8 degree texels, each visible
  // or not); a narrower lobe is importance-sampled (GGX half vectors, stratified, turned per
  // pixel) with bilinear lookups of the full-resolution room.
  glm::dvec3 shade_metallic_roughness(const glm::dvec3& origin, const glm::dvec3& n,
                                      const glm::dvec3& v, std::uint32_t pixel_seed) const {
    const render::MetallicRoughness& pbr = *material.pbr;
    const glm::dvec3 base(pbr.base_colour);
    const double metallic = pbr.metallic, roughness = pbr.roughness;
    const double alpha = roughness * roughness, a2 = std::max(alpha * alpha, 1e-12);
    const bool wide = alpha >= kWideLobe;
    const glm::dvec3 f0 = glm::mix(glm::dvec3(0.04), base, metallic);
    const double nv = glm::dot(n, v);
    glm::dvec3 out(0.0);
    for (const Direction& d : fine) {
      const double nl = glm::dot(n, d.dir);
      if (nl <= 0 || occluded(origin, d.dir)) continue;
      out += d.weighted * multiple_scattering->brdf(nl, nv, f0) * nl;
      if (wide) {
        out += d.weighted * metallic_roughness_brdf(n, d.dir, v, base, metallic, roughness) * nl;
      } else {  // the diffuse part only: (1 - F_0.04) x Lambert (glTF's fresnel_mix)
        const double f = schlick_fresnel(glm::dvec3(0.04), glm::dot(v, glm::normalize(d.dir + v))).x;
        out += d.weighted * (1.0 - f) * (1.0 - metallic) * base / kPi * nl;
      }
    }
    if (wide) return out;
    glm::dvec3 t, b;
    basis(n, t, b);
    glm::dvec3 specular(0.0);
    const int count = stratified(options.ggx_samples, pixel_seed, [&](double u1, double u2) {
      const double cos2 = (1.0 - u2) / (1.0 + (a2 - 1.0) * u2);
      const double ct = std::sqrt(cos2), st = std::sqrt(std::max(0.0, 1.0 - cos2));
      const double phi = 2 * kPi * u1;
      const glm::dvec3 h = st * std::cos(phi) * t + st * std::sin(phi) * b + ct * n;
      const double vh = glm::dot(v, h);
      const glm::dvec3 l = 2.0 * vh * h - v;
      const double nl = glm::dot(n, l);
      if (nl <= 0 || vh <= 0 || occluded(origin, l)) return;
      // F D V n.l / pdf(l), pdf(l) = D n.h / (4 v.h): F V 4 v.h n.l / n.h.
      specular += glm::dvec3(sampler.sample(l, 0.0)) * schlick_fresnel(f0, vh) *
                  (ggx_visibility(nv, nl, a2) * 4.0 * vh * nl / ct);
    });
    return out + specular / double(count);
  }

  // kd Ld + ks Ls at a surface point (normal n, the ray arriving along `view`), or the
  // metallic-roughness material's full BRDF.
  glm::dvec3 shade(const glm::dvec3& p, glm::dvec3 n, const glm::dvec3& view,
                   std::uint32_t pixel_seed) const {
    if (glm::dot(n, view) > 0) n = -n;  // seen from behind (an open mesh)
    const glm::dvec3 origin = p + epsilon * n;
    if (material.pbr) return shade_metallic_roughness(origin, n, -view, pixel_seed);
    // Ld: sum L V max(0, n.w) / sum max(0, n.w) dOmega; the denominator is pi exactly.
    glm::dvec3 diffuse(0.0);
    for (const Direction& d : directions) {
      const double c = glm::dot(d.dir, n);
      if (c > 0 && !occluded(origin, d.dir)) diffuse += c * d.weighted;
    }
    diffuse /= kPi;
    glm::dvec3 out = glm::dvec3(material.kd) * diffuse;
    if (material.ks == glm::vec3(0.0f)) return out;
    // Ls: the Phong lobe around the mirror direction, importance sampled (pdf ~ cos^s, so the
    // lobe-weighted average is the mean of what the samples see), stratified and turned per pixel.
    const glm::dvec3 r = glm::reflect(view, n);
    glm::dvec3 t, b;
    basis(r, t, b);
    const double s = material.shininess;
    glm::dvec3 glossy(0.0);
    const int count = stratified(options.glossy_samples, pixel_seed, [&](double u, double v) {
      const double cos_t = std::pow(u, 1.0 / (s + 1.0)),
                   sin_t = std::sqrt(std::max(0.0, 1.0 - cos_t * cos_t)), phi = 2 * kPi * v;
      const glm::dvec3 w = cos_t * r + sin_t * (std::cos(phi) * t + std::sin(phi) * b);
      // Below the surface the object hides the lobe from itself.
      if (glm::dot(w, n) <= 0 || occluded(origin, w)) return;
      glossy += glm::dvec3(sampler.sample(w, 0.0));
    });
    glossy /= double(count);
    return out + glm::dvec3(material.ks) * glossy;
  }

  struct Hit {
    double t;
    glm::dvec3 point, normal;
  };
  std::optional<Hit> intersect(const glm::dvec3& origin, const glm::dvec3& dir) const {
    RTCIntersectContext context;
    rtcInitIntersectContext(&context);
    RTCRayHit rh{};
    rh.ray.org_x = float(origin.x), rh.ray.org_y = float(origin.y), rh.ray.org_z = float(origin.z);
    rh.ray.dir_x = float(dir.x), rh.ray.dir_y = float(dir.y), rh.ray.dir_z = float(dir.z);
    rh.ray.tnear = 0.0f;
    rh.ray.tfar = std::numeric_limits<float>::infinity();
    rh.ray.mask = 0xFFFFFFFFu;
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rtcIntersect1(scene, &context, &rh);
    if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return std::nullopt;
    const std::uint32_t* tri = &indices[3 * std::size_t(rh.hit.primID)];
    const double u = rh.hit.u, v = rh.hit.v;
    const glm::dvec3 n = (1 - u - v) * glm::dvec3(normals[tri[0]]) +
                         u * glm::dvec3(normals[tri[1]]) + v * glm::dvec3(normals[tri[2]]);
    const double len = glm::length(n);
    const glm::dvec3 ng = glm::normalize(glm::dvec3(rh.hit.Ng_x, rh.hit.Ng_y, rh.hit.Ng_z));
    return Hit{rh.ray.tfar, origin + double(rh.ray.tfar) * dir, len > 1e-12 ? n / len : ng};
  }

  // Bilinear in the shadow grid; 1 outside it.
  glm::vec3 ratio_at(const glm::dvec3& p) const {
    const int n = options.shadow_grid;
    const glm::dvec3 d = p - floor_origin;
    const double gx = (glm::dot(d, floor_u) / grid_half * 0.5 + 0.5) * n - 0.5,
                 gy = (glm::dot(d, floor_v) / grid_half * 0.5 + 0.5) * n - 0.5;
    if (!(gx >= 0 && gy >= 0 && gx <= n - 1 && gy <= n - 1)) return glm::vec3(1.0f);
    const int x0 = std::min(int(gx), n - 2), y0 = std::min(int(gy), n - 2);
    const float fx = float(gx - x0), fy = float(gy - y0);
    const auto at = [&](int x, int y) { return grid[std::size_t(y) * std::size_t(n) + x]; };
    return (1 - fy) * ((1 - fx) * at(x0, y0) + fx * at(x0 + 1, y0)) +
           fy * ((1 - fx) * at(x0, y0 + 1) + fx * at(x0 + 1, y0 + 1));
  }
};

ReferenceScene::ReferenceScene(const PlacedObject& object, const EnvMap& room,
                               const ReferenceOptions& options)
    : impl_(std::make_unique<Impl>(room, options)) {
  Impl& m = *impl_;
  const render::Mesh& mesh = object.mesh;
  if (mesh.triangle_count() == 0 || mesh.normals.size() != mesh.positions.size())
    throw InputError("reference: the object has no triangles (or no normal per vertex)");
  const render::MetallicRoughness* pbr = object.material.pbr ? &*object.material.pbr : nullptr;
  if (object.material.transmissive() || object.material.albedo || object.material.normal_map ||
      object.material.light_map ||
      (pbr && (pbr->metallic_roughness || pbr->occlusion || pbr->emissive_map)))
    throw InputError(
        "reference: only opaque materials without textures can be traced (kd, ks, "
        "shininess, or metallic-roughness factors)");
  if (!(object.height_m > 0)) throw InputError("reference: the object's height must be > 0");
  if (options.glossy_samples < 1 || options.ggx_samples < 1 || options.shadow_grid < 2 ||
      !(options.shadow_reach > 0))
    throw std::invalid_argument("reference: bad options");
  m.material = object.material;

  // The object in the world: marker -> world after the clients' placement on the marker.
  const glm::dmat4 to_world =
      matrix_of(object.marker_to_world) *
      glm::dmat4(render::standing_on_marker(mesh.bounds, float(object.height_m)));
  const glm::dmat3 normal_matrix = glm::transpose(glm::inverse(glm::dmat3(to_world)));
  m.positions.reserve(mesh.positions.size());
  glm::dvec3 lo(std::numeric_limits<double>::max()), hi(-std::numeric_limits<double>::max());
  for (std::size_t i = 0; i < mesh.positions.size(); ++i) {
    const glm::dvec3 p = glm::dvec3(to_world * glm::dvec4(glm::dvec3(mesh.positions[i]), 1.0));
    m.positions.emplace_back(p);
    m.normals.emplace_back(glm::normalize(normal_matrix * glm::dvec3(mesh.normals[i])));
    lo = glm::min(lo, p), hi = glm::max(hi, p);
  }
  m.indices = mesh.indices;
  for (const std::uint32_t i : m.indices)
    if (i >= m.positions.size()) throw InputError("reference: a triangle index is out of range");
  m.radius = 0.5 * glm::length(hi - lo);
  m.epsilon = 1e-4 * m.radius;

  m.device = rtcNewDevice(nullptr);
  if (!m.device) throw std::runtime_error("reference: Embree could not start a device");
  m.scene = rtcNewScene(m.device);
  RTCGeometry geometry = rtcNewGeometry(m.device, RTC_GEOMETRY_TYPE_TRIANGLE);
  auto* vertices = static_cast<float*>(rtcSetNewGeometryBuffer(geometry, RTC_BUFFER_TYPE_VERTEX, 0,
                                                               RTC_FORMAT_FLOAT3, 3 * sizeof(float),
                                                               m.positions.size()));
  for (std::size_t i = 0; i < m.positions.size(); ++i)
    for (int k = 0; k < 3; ++k) vertices[3 * i + std::size_t(k)] = m.positions[i][k];
  auto* triangles = static_cast<std::uint32_t*>(
      rtcSetNewGeometryBuffer(geometry, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                              3 * sizeof(std::uint32_t), m.indices.size() / 3));
  std::copy(m.indices.begin(), m.indices.end(), triangles);
  rtcCommitGeometry(geometry);
  rtcAttachGeometry(m.scene, geometry);
  rtcReleaseGeometry(geometry);
  rtcCommitScene(m.scene);

  const EnvMap small = room_for_sums(room);
  m.directions = room_directions(small);
  if (pbr) {
    m.fine = room_directions(room_for_sums(room, kFineWidth));
    m.multiple_scattering.emplace(pbr->roughness);
  }

  // The floor: the marker's plane (its z axis is the floor's normal), the grid centred on the
  // object's foot.
  const glm::dmat3 marker_axes = glm::mat3_cast(object.marker_to_world.orientation);
  m.floor_origin = object.marker_to_world.position;
  m.floor_u = marker_axes[0], m.floor_v = marker_axes[1], m.floor_normal = marker_axes[2];
  m.grid_half = options.shadow_reach * m.radius;
  const int n = options.shadow_grid;
  m.grid.assign(std::size_t(n) * std::size_t(n), glm::vec3(1.0f));
  // The floor's ratio per channel over the same directions as the diffuse sums (the tests'
  // ShadowReference, here in the world frame).
  const Occluder occluder(m.positions, m.indices);
  const ShadowReference floor(small, glm::dmat3(1.0), m.floor_normal);
  tbb::parallel_for(0, n, [&](int y) {
    for (int x = 0; x < n; ++x) {
      const double a = ((x + 0.5) / n * 2 - 1) * m.grid_half,
                   b = ((y + 0.5) / n * 2 - 1) * m.grid_half;
      m.grid[std::size_t(y) * std::size_t(n) + std::size_t(x)] =
          glm::vec3(floor.ratio_rgb(occluder, m.floor_origin + a * m.floor_u + b * m.floor_v));
    }
  });
}

ReferenceScene::~ReferenceScene() = default;

double ReferenceScene::shadow_ratio(const glm::dvec3& world_point) const {
  return double(glm::dot(impl_->ratio_at(world_point), glm::vec3(0.2126f, 0.7152f, 0.0722f)));
}

std::optional<glm::vec3> ReferenceScene::object_radiance(const glm::dvec3& origin,
                                                         const glm::dvec3& dir) const {
  const glm::dvec3 d = glm::normalize(dir);
  const auto hit = impl_->intersect(origin, d);
  if (!hit) return std::nullopt;
  // Each ray its own turn of the stratified samples (a hash of its direction).
  std::uint32_t seed = 0;
  for (int k = 0; k < 3; ++k) seed = hash(seed ^ std::uint32_t(std::lround((d[k] + 1.0) * 1e6)));
  return glm::vec3(impl_->shade(hit->point, hit->normal, d, seed));
}

ReferenceView ReferenceScene::render(const CameraIntrinsics& intrinsics,
                                     const Pose& camera_to_world, const cv::Mat& frame,
                                     double exposure_gain, const CameraResponse& response) const {
  const Impl& m = *impl_;
  if (frame.type() != CV_8UC3 || frame.cols != intrinsics.width || frame.rows != intrinsics.height)
    throw InputError("reference: the frame is not 8-bit BGR of the camera's size (" +
                     std::to_string(intrinsics.width) + "x" + std::to_string(intrinsics.height) +
                     ")");
  if (!(exposure_gain > 0)) throw InputError("reference: the frame's exposure x gain must be > 0");
  const PinholeCamera camera(intrinsics);
  ReferenceView out;
  out.composite = frame.clone();
  out.object_mask = cv::Mat::zeros(frame.size(), CV_8U);
  out.shadow_mask = cv::Mat::zeros(frame.size(), CV_8U);
  out.shadow_ratio = cv::Mat(frame.size(), CV_32FC3, cv::Scalar(1, 1, 1));
  const auto code = [&](double linear, int channel) {
    return std::uint8_t(std::lround(255.0 * response.encode(float(linear), channel)));
  };
  tbb::parallel_for(0, frame.rows, [&](int y) {
    for (int x = 0; x < frame.cols; ++x) {
      const glm::dvec3 dir =
          glm::normalize(camera_to_world.orientation * camera.unproject({double(x), double(y)}));
      const glm::dvec3 origin = camera_to_world.position;
      auto* px = out.composite.ptr<cv::Vec3b>(y) + x;
      if (const auto hit = m.intersect(origin, dir)) {
        const glm::dvec3 l =
            m.shade(hit->point, hit->normal, dir, std::uint32_t(y) * 65536U + std::uint32_t(x));
        for (int c = 0; c < 3; ++c) (*px)[2 - c] = code(l[c] * exposure_gain, c);
        out.object_mask.at<std::uint8_t>(y, x) = 255;
        continue;
      }
      const double denom = glm::dot(dir, m.floor_normal);
      if (denom >= 0) continue;  // looking up: no floor
      const double t = glm::dot(m.floor_origin - origin, m.floor_normal) / denom;
      if (t <= 0) continue;
      const glm::vec3 ratio = m.ratio_at(origin + t * dir);
      if (ratio == glm::vec3(1.0f)) continue;
      out.shadow_ratio.at<cv::Vec3f>(y, x) = cv::Vec3f(ratio.b, ratio.g, ratio.r);
      for (int c = 0; c < 3; ++c)
        (*px)[2 - c] = code(response.linear((*px)[2 - c], c) * ratio[c], c);
      if (glm::dot(ratio, glm::vec3(0.2126f, 0.7152f, 0.0722f)) < m.options.shadow_mask_below)
        out.shadow_mask.at<std::uint8_t>(y, x) = 255;
    }
  });
  return out;
}

std::vector<std::size_t> write_references(const std::filesystem::path& rec,
                                          const ReferenceObject& object, const EnvMap& room,
                                          const ReferenceOptions& options, int every) {
  namespace fs = std::filesystem;
  if (every < 1) throw InputError("reference: every must be >= 1");
  const recording::Recording recording = recording::read_recording(rec);
  const std::optional<recording::Truth> truth = recording::read_truth(rec);
  if (!truth) throw InputError(rec.string() + ": no truth/ (only simulated recordings have one)");
  if (!truth->marker)
    throw InputError(rec.string() + ": the recording has no marker to stand the object on");
  if (truth->poses.size() != recording.frames.size())
    throw InputError(rec.string() + ": truth has " + std::to_string(truth->poses.size()) +
                     " poses for " + std::to_string(recording.frames.size()) + " frames");
  const fs::path response_file = rec / recording::kTruthFolder / "response.json";
  const CameraResponse response = fs::exists(response_file)
                                      ? CameraResponse::load(response_file)
                                      : CameraResponse::named(truth->response);
  EnvMap scaled = room;
  for (float& v : scaled.image.storage()) v *= float(truth->radiance_scale);
  const ReferenceScene scene({object.mesh, object.material, object.height_m, truth->marker->pose},
                             scaled, options);

  const fs::path dir = rec / recording::kTruthFolder / kReferenceFolder;
  fs::remove_all(dir);
  fs::create_directories(dir);
  std::vector<std::size_t> done;
  int seen = 0;
  for (std::size_t i = 0; i < recording.frames.size(); ++i) {
    if (!truth->marker_visible.at(i) || !recording.frames[i].problem.empty()) continue;
    if (seen++ % every != 0) continue;
    const std::vector<std::uint8_t> bytes = recording::read_frame_bytes(recording, i);
    const cv::Mat frame = cv::imdecode(bytes, cv::IMREAD_COLOR);
    if (frame.empty()) throw InputError(recording.frames[i].file + ": not a decodable image");
    const recording::Frame& f = recording.frames[i];
    const ReferenceView view =
        scene.render(recording.camera, truth->poses[i], frame, f.exposure * f.gain, response);
    char name[32];
    std::snprintf(name, sizeof name, "%06zu", i);
    const std::string stem = (dir / name).string();
    if (!cv::imwrite(stem + ".png", view.composite) ||
        !cv::imwrite(stem + "_object.png", view.object_mask) ||
        !cv::imwrite(stem + "_shadow.png", view.shadow_mask))
      throw std::runtime_error(stem + ".png: could not be written");
    done.push_back(i);
  }
  const nlohmann::json manifest = {{"format", "arlight-reference"},
                                   {"version", 1},
                                   {"model", object.model},
                                   {"material",
                                    {{"kd", object.material.kd.x},
                                     {"ks", object.material.ks.x},
                                     {"shininess", object.material.shininess}}},
                                   {"height_m", object.height_m},
                                   {"frames", done}};
  write_file_atomically(dir / "reference.json", manifest.dump(2) + "\n");
  return done;
}

}  // namespace arlight::reference
