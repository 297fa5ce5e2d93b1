// Radiance transfer baked by ray casting (tutorial §6.1, Sloan et al. 2002's precomputed
// radiance transfer; thesis Alg. 5.2's light maps come from it): for points on a mesh or on a
// receiver plane, how much of the distant light each direction brings once the mesh's own
// occlusion is counted, as ambient occlusion, a bent normal and low-order SH coefficients.
// Dotted with a lighting's SH at run time, the transfer gives the occluded diffuse light
// that follows the room as it changes. The native client bakes at model load (occlusion_bake),
// arlight-model for the page's models (the page's WebAssembly build never ray-casts), the
// laboratory for its shadow references. Ray casting is Embree 3's; points are baked on all cores.
#pragma once

#include <cstdint>
#include <glm/mat3x3.hpp>
#include <glm/vec3.hpp>
#include <span>
#include <vector>

#include "arlight/common/projection.hpp"
#include "arlight/common/sh.hpp"

namespace arlight {

struct TransferOptions {
  // On a Fibonacci sphere (equal solid angles, no poles). 1,024 puts the bunny's occlusion within
  // 0.0026 rms (0.009 at the 99th percentile) of 8,192's, its bent normals within 0.7 degrees.
  int directions = 1024;
  int order = 3;  // SH order of the transfer (3: 9 coefficients, the bands of SH-9)
};

// Per point, for the cosine lobe around its normal n with visibility V (1 where no triangle of
// the mesh is in the way), over directions w of solid angle dw:
//   ao      = sum V max(0, n.w) dw / pi                 (1: nothing hidden; at most 1)
//   bent    = normalize(sum V max(0, n.w) w dw)         (n when nothing is visible)
//   sh[k]   = sum V max(0, n.w) Y_k(w) dw / pi
// so that sum_k sh[k] L_k for a radiance SH L is the lobe-averaged radiance the point receives
// (the irradiance map's convention, DESIGN.md), and for a constant room of radiance 1 it is ao.
struct Transfer {
  int order = 3;
  std::vector<float> ao;
  std::vector<glm::vec3> bent_normal;
  std::vector<float> sh;  // sh_count(order) per point, point-major
  std::size_t size() const { return ao.size(); }
  // sum_k sh[k] L_k for point i (L in the same frame as the points).
  glm::dvec3 apply(std::size_t i, const ShCoeffs& lighting) const;
};

// The mesh's triangles as an occluder (Embree BVH); thread-safe to query.
class Occluder {
 public:
  // Throws std::invalid_argument for indices out of range or not a multiple of 3.
  Occluder(std::span<const glm::vec3> positions, std::span<const std::uint32_t> indices);
  ~Occluder();
  Occluder(const Occluder&) = delete;
  Occluder& operator=(const Occluder&) = delete;

  // Whether the ray from `origin` along `dir` meets a triangle.
  bool occluded(const glm::dvec3& origin, const glm::dvec3& dir) const;
  // The same for many directions from one origin (traced as coherent packets of 16, ~2x the
  // rays per second of one at a time): hit[i] = 1 where dirs[i] meets a triangle.
  void occluded(const glm::dvec3& origin, std::span<const glm::dvec3> dirs,
                std::span<std::uint8_t> hit) const;
  // The mesh's bounding-sphere radius (for ray offsets).
  double radius() const { return radius_; }

 private:
  struct Impl;
  Impl* impl_;
  double radius_ = 0;
};

// The transfer of points (with unit normals) under the occluder: the mesh's own vertices (with
// their normals) for self-shadowing, or points of a receiver plane for the mesh's shadow on it.
Transfer bake_transfer(const Occluder& occluder, std::span<const glm::vec3> points,
                       std::span<const glm::vec3> normals, const TransferOptions& options = {});

// The reference for shadows on a receiver plane (tutorial §6's ray-traced comparison; the
// shadows of arlight-sim's reference renders): the ratio of the irradiance a point of the plane
// gets with the occluder to without it, over every texel of an environment map (no sampling:
// each texel one ray from its centre),
//   ratio = sum L w max(0, n.d) V / sum L w max(0, n.d),
// per channel, or of the luminance. The map is in the world frame, the occluder and points in
// the scene frame.
class ShadowReference {
 public:
  // Negative radiance (lossy probes) counts as 0; texels without light or under the plane's
  // horizon are dropped.
  ShadowReference(const EnvMap& world_map, const glm::dmat3& scene_from_world, glm::dvec3 normal);
  double ratio(const Occluder& occluder, const glm::dvec3& point) const;  // of the luminance
  glm::dvec3 ratio_rgb(const Occluder& occluder, const glm::dvec3& point) const;
  // The luminance ratio at many points, on all cores.
  std::vector<double> ratios(const Occluder& occluder, std::span<const glm::dvec3> points) const;

 private:
  glm::dvec3 normal_;
  std::vector<glm::dvec3> dirs_;     // scene frame
  std::vector<glm::dvec3> weights_;  // L w cos, per channel
  glm::dvec3 total_{0.0};
};

}  // namespace arlight
