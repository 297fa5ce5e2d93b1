// arlight_render: the client's GLES 3 renderer (thesis ch. 5; tutorial §4.1).
//
//   GlContext ctx = GlContext::headless();
//   Renderer r(1280, 720);                      // shaders from ARLIGHT_SHADER_DIR
//   GpuMesh bunny(load_gltf("bunny.glb"));
//   r.set_sh(live_sh);                           // until the map set arrives ...
//   r.set_maps(shininess, maps);                 // ... then irradiance + reflection maps
//   r.set_camera(intrinsics, camera_from_scene); // marker pose from tracking
//   r.set_world_from_scene(world_from_scene);    // scene (marker) frame -> lighting frame
//   r.begin_frame();
//   r.draw(bunny, material, model);
//   r.set_shadow({.enabled = true, .light_direction = d, .light_colour = c});  // optional
//   r.composite(frame_bgr, {ToneMode::CameraMatched, exposure, gain}, out_bgr);
//
// Frames and results are 8-bit BGR images (ImageU8View / ImageU8, OpenCV's channel order) of the
// renderer's size, row 0 at the top; arlight/render/opencv.hpp bridges cv::Mat natively. The
// core needs no OpenCV, oneTBB or EGL (it builds for WebGL2 too): only a current GLES 3 context.
// Every GL object lives in the context current when the Renderer was made.
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <glm/gtc/quaternion.hpp>
#include <glm/mat3x3.hpp>
#include <glm/mat4x4.hpp>
#include <memory>
#include <optional>
#include <span>
#include <string_view>
#include <vector>

#include "arlight/common/camera.hpp"
#include "arlight/common/image.hpp"
#include "arlight/common/image_u8.hpp"
#include "arlight/common/projection.hpp"
#include "arlight/common/response.hpp"
#include "arlight/common/sh.hpp"
#include "arlight/common/specular_lights.hpp"
#include "arlight/render/colour.hpp"
#include "arlight/render/gl_context.hpp"
#include "arlight/render/material.hpp"
#include "arlight/render/gltf.hpp"
#include "arlight/render/mesh.hpp"
#include "arlight/render/shader.hpp"

namespace arlight::render {

// A mesh in GPU buffers (VAO + vertex and index buffers); needs a current context.
class GpuMesh {
 public:
  explicit GpuMesh(const Mesh& mesh);
  GpuMesh(GpuMesh&&) noexcept;
  GpuMesh& operator=(GpuMesh&&) noexcept;
  GpuMesh(const GpuMesh&) = delete;
  GpuMesh& operator=(const GpuMesh&) = delete;
  ~GpuMesh();

  bool has_uvs() const { return has_uvs_; }
  bool has_tangents() const { return has_tangents_; }
  bool has_occlusion() const { return has_occlusion_; }
  bool has_transfer() const { return has_transfer_; }  // Mesh::transfer, attributes 5-7
  // The baked floor occlusion (Mesh::ground) as an R8 texture, and its rectangle; 0 / empty
  // when none was baked.
  unsigned ground_texture() const { return ground_tex_; }
  // Its SH-9 hidden transfer (GroundOcclusion::hidden_transfer) as a 3-layer RGBA16F array
  // texture (layer j: coefficients 3j..3j+2), or 0 when none was baked.
  unsigned ground_transfer_texture() const { return ground_transfer_tex_; }
  const GroundOcclusion& ground_rect() const { return ground_rect_; }
  std::size_t index_count() const { return index_count_; }
  // Mesh::parts, or one part of every index (material -1) for a mesh without.
  const std::vector<MeshPart>& parts() const { return parts_; }
  const Bounds& bounds() const { return bounds_; }
  unsigned vao() const { return vao_; }

 private:
  void release();
  unsigned vao_ = 0, vbo_ = 0, ibo_ = 0, ground_tex_ = 0, ground_transfer_tex_ = 0;
  GroundOcclusion ground_rect_;  // min, max and size only
  std::size_t index_count_ = 0;
  std::vector<MeshPart> parts_;
  bool has_uvs_ = false, has_tangents_ = false, has_occlusion_ = false, has_transfer_ = false;
  Bounds bounds_;
};

enum class ToneMode {
  // Tutorial §4.1: the virtual radiance goes through the frame's exposure and the camera's
  // response, code = response.encode(L * exposure * gain) per channel, like the real pixels.
  CameraMatched,
  // Thesis Alg. 5.5 (eq. 5.5/5.6), fixed: log-average luminance of the masked pixels only,
  // colour scaled by L_d / L_w; the result is sRGB-encoded for display.
  Reinhard,
  // clamp(L * exposure * gain) written as is (no curve); for debugging.
  Linear,
};

struct ToneMapping {
  ToneMode mode = ToneMode::CameraMatched;
  double exposure = 1.0;  // the frame's exposure time (s); radiance = linear / (exposure * gain)
  double gain = 1.0;      // the frame's analogue/digital gain
  float key = 0.18f;      // Reinhard's key value a
  float white = 2.0f;     // Reinhard's L_white (scaled luminance that maps to white)
  // Dissertation §5.6's colour correction of the virtual pixels against the room's colour
  // priors (Renderer::environment_priors()); off by default.
  ColourCorrection colour = ColourCorrection::None;
};

enum class LightingSource { None, Sh, Maps };

// How draw() turns the lighting into the object's radiance.
enum class Shading {
  // Thesis Alg. 5.1: the irradiance map at the normal, the reflection maps at the reflected
  // direction (the map set, or the live SH's maps until it arrives).
  ImageBased,
  // Dissertation §5.4.1, eq. 6: two colours blended by the normal's elevation,
  //   L(n) = a c_u + (1 - a) c_l,  a = 0.5 + 0.5 n.up,
  // for the diffuse term at the normal and the specular term at the reflected direction. Exact
  // for an environment of two uniform hemispheres; the fallback for devices too weak for maps.
  Hemisphere,
  // Eq. 6 times hemisphere occlusion (§5.4.2): a grey factor blended the same way from 1 (up)
  // to shadow / light (down), the darkest over the lightest side of the room.
  HemisphereOcclusion,
};

// The clients' names of the modes (arlight-client --shading, the page's control): "maps",
// "hemisphere", "hemisphere-occlusion".
const char* shading_name(Shading shading);
std::optional<Shading> shading_named(std::string_view name);

// What a transmissive material (Material::transmission, glass) shows through it.
enum class Refraction {
  // The reflection maps (or eq. 6) in the direction the ray leaves the object: the room as
  // captured (dissertation §5.5.1).
  Maps,
  // The camera frame itself where that ray meets the real floor (the scene's z = 0) or, going up,
  // far away (dissertation §5.5.3, live feed): what is behind the object now, a person walking
  // past included. Drawn after the opaque objects, in composite(), over a copy of the frame
  // (screen-space refraction, as Filament does); rays that leave the frame fall back to the maps.
  // Virtual objects behind the glass do not show through it.
  LiveFrame,
};
// The clients' names (arlight-client --glass, the page's control): "maps", "live".
const char* refraction_name(Refraction refraction);
std::optional<Refraction> refraction_named(std::string_view name);

// The colour priors of hemisphere shading (dissertation §5.4), from the current lighting (the
// irradiance map, or the live SH's irradiance until it arrives), world frame.
struct HemispherePriors {
  // c_u, c_l: the cosine-weighted mean radiance of the upper / lower hemisphere (the
  // irradiance map at +Y / -Y). The dissertation took the plain mean of the top / bottom cube
  // face (a 55-degree cone); the cosine-weighted mean makes eq. 6 exact at the poles.
  glm::vec3 upper{0.0f}, lower{0.0f};
  // Occlusion's light and shadow: the largest and smallest luminance of the irradiance map over
  // 16 horizontal normals (the lit and the dark side of the room). The dissertation took the
  // lightest and darkest single pixel of the four side faces: one lamp or one dark corner
  // decided it.
  float light = 0.0f, shadow = 0.0f;
};
enum class ReflectionLookup { Interpolate, Nearest };

struct FrameTimings {
  double render_ms = 0;    // begin_frame() to the end of the draws (glFinish)
  double tonemap_ms = 0;   // upload of the camera frame, shadow, reduction, tone map, composite
  double shadow_ms = 0;    // the shadow map and the shadow catcher (part of tonemap_ms)
  double refraction_ms = 0;  // live refraction: the frame's copy and the glass (in tonemap_ms)
  double readback_ms = 0;  // glReadPixels and conversion to BGR
  int shadow_lights = 0;   // the hard shadows the last composite's soft shadow blended
  double total() const { return render_ms + tonemap_ms + readback_ms; }
};

// The shadow catcher (tutorial §6.3, differential rendering): the plane z = 0 of the scene
// (marker) frame receives the shadows of the objects drawn this frame, and the camera frame's
// pixels there are scaled by the ratio of the plane's irradiance with the objects to without:
//   ratio = max(min_ratio, 1 - f (1 - V) - (1 - f) AO)
// with f the dominant light's share of the plane's irradiance (under a map set, the sum over
// `lights` clusters of f_i (1 - V_i) instead: see `lights` below),
//   f = clamp(lum(light_colour) max(0, l.n) / (pi lum(Lbar(n))), 0, max_fraction),
// n the plane's normal and l the light direction (world frame), Lbar(n) the irradiance map's
// value there (irradiance / pi, from the maps or the SH); V the light's visibility from an
// orthographic shadow map fitted to the objects' bounds (PCF); AO the cosine-weighted share of
// the remaining (sky) irradiance hidden by the objects: baked by ray casting for a mesh with its
// floor occlusion baked (Mesh::ground) standing on the floor, else taken as the ellipsoid
// inscribed in its bounds. Only the composited output changes: the mask, the HDR target and
// Reinhard's log-average are the objects' alone, and pixels whose ratio rounds to 1 keep the frame
// exactly.
struct ShadowSettings {
  bool enabled = false;
  // The dominant light as arlightd sends it (LightingUpdate): unit direction towards the light
  // in the world frame, and its colour: irradiance at normal incidence (the SH bands 0-1
  // estimate). A black colour leaves only the contact (AO) shadow.
  glm::vec3 light_direction{0.0f, 1.0f, 0.0f};
  glm::vec3 light_colour{0.0f};
  int map_size = 256;            // shadow map texels per side
  float pcf_step = 1.5f;         // texels between the 3x3 PCF taps (each a 2x2 bilinear compare)
  float max_fraction = 0.85f;    // f's upper clamp (some light always reaches a real floor)
  float ao_strength = 1.0f;      // scales AO (0: no contact shadow)
  float ao_reach = 3.0f;         // AO fades to 0 at this many half-extents from an object
  float max_shadow_length = 4.0f;  // the plane reaches at most this many object sizes
  float min_ratio = 0.15f;       // the darkest the floor gets
  // Soft shadows under a map set (tutorial §6): its sharpest map's brightest texels holding
  // source_share of the floor's light are median-cut into clusters (build_light_tree), and
  // `lights` of them (select_lights; at most kMaxShadowLights) each cast a hard shadow from
  // their centroid, weighted by their share of the floor's irradiance (their f_i, summing to
  // about source_share); the rest of the light shadows through AO. The lights above are then
  // unused; under the live SH alone they are the one light. A cluster wider than max_spread
  // (its texels' mean angle from its centre, radians) casts no hard shadow of its own: one hard
  // shadow is a poor stand-in for a broad light (an overcast sky, a uniform room), so its share
  // joins the AO's, which is exact for a uniform sky and, where the floor's transfer is baked,
  // follows any smooth sky. (0.25 rad let 8 patches of an overcast sky cast hard shadows: 1.9 %
  // off the ray-traced ratio beside a standing ball, against 0.8 % through its floor's transfer.)
  int lights = 8;
  float source_share = 0.7f;
  float max_spread = 0.12f;
};
inline constexpr int kMaxShadowLights = 32;  // shadow_catcher.frag's MAX_LIGHTS

// Tutorial §6.4's frame-rate control: how many lights (ShadowSettings::lights) hold a target
// frame time. Each frame reports its time; after two frames over the target the count drops in
// proportion at once (at least by one), and after kPatience frames in a row under kHeadroom x
// the target it grows by one, so it settles just under the target and follows a renderer that
// slows down or speeds up.
class LightCountControl {
 public:
  // Throws std::invalid_argument for a target <= 0 or max_lights outside [1, kMaxShadowLights].
  LightCountControl(double target_ms, int max_lights, int start = 1);
  // One frame drawn with lights() lights took frame_ms; returns the count for the next frame.
  int update(double frame_ms);
  int lights() const { return lights_; }
  double target_ms() const { return target_ms_; }

 private:
  double target_ms_;
  int max_lights_, lights_;
  int calm_frames_ = 0;
  double last_ms_ = 0;
  static constexpr double kHeadroom = 0.85;
  static constexpr int kPatience = 4;
};

struct HdrReadback {
  Image radiance;                  // linear RGB as rendered (half float), row 0 at the top
  std::vector<std::uint8_t> mask;  // 1 where a virtual object was drawn, else 0
};

// OpenGL projection of a pinhole camera given by OpenCV intrinsics (fx, fy, cx, cy; pixel
// centres at integers) for a viewport of width x height whose row 0 is the image's top row
// (the renderer's targets are stored top row first). Camera coordinates: x right, y up,
// looking down -z. Distortion is not applied. Intrinsics of another size are scaled.
glm::mat4 projection_from_intrinsics(const CameraIntrinsics& k, int width, int height,
                                     float near_plane, float far_plane);

class Renderer {
 public:
  // Needs a current ES 3 context with EXT_color_buffer_float (GlError otherwise).
  Renderer(int width, int height, const std::filesystem::path& shader_dir = default_shader_dir());
  ~Renderer();
  Renderer(const Renderer&) = delete;
  Renderer& operator=(const Renderer&) = delete;

  int width() const;
  int height() const;

  // ---- lighting (world frame) ----
  // Live SH from the daemon: diffuse = SH convolved with the clamped-cosine lobe (thesis eq.
  // 2.33, s = 1), specular = SH convolved with the Phong lobe of a few shininess values, both
  // evaluated into small lat-long maps on the CPU and shaded like the map set. Used until
  // set_maps() is called (and again after clear_maps()). Unchanged coefficients cost nothing.
  void set_sh(const ShCoeffs& sh);
  // The map set: one map per shininess, all of one projection (sizes may differ). The smallest
  // shininess (1) is the irradiance map; every map is a reflection-map candidate. Uploaded once
  // as half-float textures. Throws std::invalid_argument on an empty or inconsistent set.
  void set_maps(const std::vector<double>& shininess, const std::vector<EnvMap>& maps);
  void clear_maps();
  // The room's GGX chain (issue 34: arlightd's RequestMaps kind Ggx, or lighting::
  // compute_ggx_chain): cube maps, level k of half the face of level k - 1, at perceptual
  // roughness 1 - sqrt(1 - k / (n - 1)) (Filament's mapping; std::invalid_argument otherwise).
  // Metallic-roughness materials take their specular from it; without one, from the reflection
  // map of the Phong shininess whose lobe is as wide (s = 1 / (2 alpha^2) - 1/2, at least 1).
  // Uploaded once as one mipmapped RGBA16F cube texture. With `lights` (split_specular_lights,
  // at most kMaxSpecularLights, world frame), the chain is the residual of the room without
  // them and metallic-roughness adds each light with the full GGX BRDF (Karis 2013's
  // representative point and widened lobe for its disc); their diffuse light is the irradiance
  // map's (or, without a map set, added to the chain's roughest level).
  void set_ggx_chain(const std::vector<EnvMap>& levels, const std::vector<double>& roughness,
                     const std::vector<SpecularLight>& lights = {});
  void clear_ggx_chain();
  bool has_ggx_chain() const;
  LightingSource lighting_source() const;
  // Reflection map for a material's shininess: interpolated in log shininess between the two
  // neighbouring maps (default) or the nearest one.
  void set_reflection_lookup(ReflectionLookup lookup);
  // Image-based (default) or hemisphere shading (see Shading).
  void set_shading(Shading shading);
  Shading shading() const;
  // What hemisphere shading uses now (zero without lighting).
  HemispherePriors hemisphere_priors() const;
  // The room's colour priors (dissertation §5.1) from the current lighting: the map set's
  // sharpest map, or the live SH's radiance (zero without lighting).
  EnvironmentPriors environment_priors() const;
  // Or these priors, whatever the lighting: a room measured elsewhere than the light the object
  // is shaded with (nullopt: the lighting's own again).
  void set_environment_priors(std::optional<EnvironmentPriors> priors);
  // What glass shows through it (default: the maps).
  void set_refraction(Refraction refraction);
  Refraction refraction() const;

  // ---- camera and frames ----
  void set_camera(const CameraIntrinsics& k, const glm::dmat4& camera_from_scene,
                  float near_plane = 0.01f, float far_plane = 100.0f);
  void set_world_from_scene(const glm::dquat& world_from_scene);
  void set_world_from_scene(const glm::dmat3& world_from_scene);
  // The camera response for CameraMatched tone mapping (default sRGB); uploaded once.
  void set_response(const CameraResponse& response);

  // ---- shadows on the real floor (see ShadowSettings); off by default ----
  void set_shadow(const ShadowSettings& settings);
  const ShadowSettings& shadow() const;
  // f of ShadowSettings for the current lighting, world_from_scene and light (0 when off);
  // under a map set, the sum of the chosen clusters' f_i.
  float shadow_fraction() const;

  // Clears the HDR target (radiance 0, mask 0) and depth, and the frame's shadow casters.
  void begin_frame();
  // Thesis Alg. 5.1-5.4: kd * Ld(n) (* light map) + ks * Ls(reflect(-v, n)), normal mapping
  // with a TBN basis, depth tested, into the RGBA16F target (alpha = mask). With shadows on,
  // the mesh also casts a shadow in composite(), and a transmissive material under
  // Refraction::LiveFrame is drawn there too: the mesh must live until then.
  void draw(const GpuMesh& mesh, const Material& material, const glm::mat4& model);
  // The same with the mesh's own materials (a glTF's, GltfModel::materials): each part with
  // materials[part.material], a part without one (or one beyond the list) with `fallback`.
  void draw(const GpuMesh& mesh, std::span<const Material> materials, const Material& fallback,
            const glm::mat4& model);
  // Tone maps the virtual pixels and composites them over the camera frame (8-bit BGR, the
  // renderer's size) in one pass; pixels outside the mask keep the frame exactly (except the
  // shadow catcher's darkening, when shadows are on). `out` is reshaped to the frame's size
  // (reallocated only when it grows); the span form writes width * height * 3 bytes, packed.
  void composite(const ImageU8View& frame_bgr, const ToneMapping& tone, ImageU8& out_bgr);
  void composite(const ImageU8View& frame_bgr, const ToneMapping& tone,
                 std::span<std::uint8_t> out_bgr);
  // The browser's way, without the frame ever on the CPU: the page uploads its video frame
  // (R, G, B, the renderer's size, top row first) into camera_texture(), the GL texture the
  // composite is made in, then composite_in_place() tone maps the objects over it there, for
  // present(), with no readback. The shadow catcher's factors are multiplied into the frame
  // there by blending (composite() applies the same factors on the CPU, before its upload). The
  // camera's response (set_response) decodes the frame for live refraction. The timings are
  // the time to issue the frame's GL calls: no glFinish (a browser would stall on it).
  unsigned camera_texture() const;
  void composite_in_place(const ToneMapping& tone);
  // Shows the last composite in a window context's default framebuffer (then swap_buffers()).
  void present();

  const FrameTimings& timings() const;
  // For tests and tools: the HDR target as rendered, and Reinhard's last log-average luminance.
  HdrReadback read_hdr();
  float last_log_average() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> p_;
};

}  // namespace arlight::render
