// Reference renders of a virtual object standing on a simulated recording's marker, under the
// true room (issue 18, tutorial §8): what the camera would have seen had the object been real.
// arlight-eval scores the clients' composites against them.
//
// Ray traced with Embree against the object's triangles, lit by the probe the recording was
// simulated in (distant light, as the clients assume):
// - object pixels: kd Ld + ks Ls (the renderer's material, DESIGN.md: lobe-weighted averages of
//   the radiance, thesis Alg. 4.1), but with the object's own visibility, which the maps
//   cannot know: the diffuse average sums every direction texel of the room (a 64x32 lat-long
//   of it) the object does not hide; the glossy average importance-samples the Phong lobe of
//   the full-resolution probe. Light the object hides from itself counts as dark (no
//   interreflection); opaque, untextured materials only. A glTF metallic-roughness material
//   (render::MetallicRoughness factors) gets its full BRDF (common/brdf.hpp) integrated over
//   the room, with the same visibility: the reference its split-sum rendering is measured
//   against (issue 34 §3).
// - the floor (the marker's plane): the camera frame's linear value times the shadow ratio,
//   sum L V cos / sum L cos over the room's upper hemisphere texels (tutorial §6.3's ratio,
//   differential rendering), computed once on a grid around the object.
// The result is encoded by the camera's response at the frame's exposure x gain, over the
// recorded frame itself (noise and JPEG included), so only the object and its shadow differ
// from the frame.
#pragma once

#include <filesystem>
#include <memory>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "arlight/common/camera.hpp"
#include "arlight/common/pose.hpp"
#include "arlight/common/projection.hpp"
#include "arlight/common/response.hpp"
#include "arlight/render/material.hpp"
#include "arlight/render/mesh.hpp"

namespace arlight::reference {

// The virtual object as the clients place it: standing on the marker (render::
// standing_on_marker), `height_m` tall.
struct PlacedObject {
  render::Mesh mesh;
  render::Material material;
  double height_m = 0.3;
  Pose marker_to_world;
};

struct ReferenceOptions {
  int glossy_samples = 64;    // Phong-lobe samples per object pixel (stratified)
  int ggx_samples = 1024;     // GGX-lobe samples of a narrow metallic-roughness lobe (stratified)
  int shadow_grid = 128;      // shadow ratio texels across the floor square around the object
  double shadow_reach = 6.0;  // that square's half side, in object bounding radii
  // A pixel counts as shadowed where the ratio is below this (the shadow mask).
  double shadow_mask_below = 0.95;
};

// One view's reference: the composite (8-bit BGR, the frame's size), where the object is (255)
// and where its shadow darkens the floor (255: ratio < shadow_mask_below, off the object), and
// the shadow ratio per pixel (1 elsewhere).
struct ReferenceView {
  cv::Mat composite, object_mask, shadow_mask, shadow_ratio;
};

class ReferenceScene {
 public:
  // `room`: the true environment's radiance in the world frame (any projection; the
  // recording's probe scaled by its truth radiance_scale). Throws InputError for a mesh
  // without triangles or a material this reference cannot render (glass, textures).
  ReferenceScene(const PlacedObject& object, const EnvMap& room, const ReferenceOptions& options);
  ~ReferenceScene();
  ReferenceScene(const ReferenceScene&) = delete;
  ReferenceScene& operator=(const ReferenceScene&) = delete;

  // The view of a camera at `camera_to_world` with these intrinsics over `frame` (8-bit BGR,
  // the camera's size) taken at `exposure_gain` (seconds x gain, the recording's linear scale).
  ReferenceView render(const CameraIntrinsics& intrinsics, const Pose& camera_to_world,
                       const cv::Mat& frame, double exposure_gain,
                       const CameraResponse& response) const;

  // The floor's shadow ratio at a world point on the marker's plane (1 outside the grid).
  double shadow_ratio(const glm::dvec3& world_point) const;
  // The object's outgoing radiance where a ray from `origin` along `dir` first meets it
  // (std::nullopt: it misses).
  std::optional<glm::vec3> object_radiance(const glm::dvec3& origin, const glm::dvec3& dir) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// What a folder of references holds (REC/truth/reference/, protocol/RECORDING.md):
// NNNNNN.png the reference composite of recording frame NNNNNN, NNNNNN_object.png and
// NNNNNN_shadow.png its masks, reference.json the object and the frames.
inline constexpr const char* kReferenceFolder = "reference";  // inside REC/truth/

struct ReferenceObject {
  std::string model;  // as the clients' --model takes it ("sphere" or a glTF file)
  render::Mesh mesh;
  render::Material material;
  double height_m = 0.3;
};

// Renders REC/truth/reference/ for a simulated recording (its truth's poses, marker and
// response; `room` is its probe) for every `every`-th frame with the marker in view, replacing
// what was there. Returns the frames rendered. InputError for a recording without truth or
// marker, or a frame that cannot be read.
std::vector<std::size_t> write_references(const std::filesystem::path& recording,
                                          const ReferenceObject& object, const EnvMap& room,
                                          const ReferenceOptions& options, int every = 1);

}  // namespace arlight::reference
