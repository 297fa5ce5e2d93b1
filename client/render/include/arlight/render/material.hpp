// Materials for image-based lighting: the thesis's Phong materials (§5.3: kd, ks, shininess,
// and optional albedo, tangent-space normal and light maps) and glTF 2.0's metallic-roughness.
#pragma once

#include <cstdint>
#include <glm/vec3.hpp>
#include <glm/vec4.hpp>
#include <memory>
#include <optional>
#include <span>
#include <string_view>
#include <vector>

#include "arlight/common/image_u8.hpp"

namespace arlight::render {

// A texture image: width x height texels of 1 (gray), 3 (RGB) or 4 (RGBA) channels, packed, row
// 0 the top of the image (uv v = 0), either 8-bit (`u8`) or linear float (`f32`, 1 or 3
// channels). `srgb` says whether 8-bit values are sRGB-encoded (albedo photos) or linear
// (normal maps, light maps); float images are always linear. The renderer uploads each
// TextureImage once and keeps it while the shared_ptr lives. Image files and cv::Mat come in
// through arlight/render/opencv.hpp (native only).
struct TextureImage {
  int width = 0, height = 0, channels = 0;
  std::vector<std::uint8_t> u8;
  std::vector<float> f32;
  bool srgb = false;
};

// 8-bit texels in R, G, B(, A) order (or gray); std::invalid_argument for an empty image or
// another channel count.
std::shared_ptr<const TextureImage> make_texture(const ImageU8View& rgb, bool srgb);
// Linear float texels, 1 or 3 channels (R, G, B), packed.
std::shared_ptr<const TextureImage> make_texture(int width, int height, int channels,
                                                 std::vector<float> linear);

// glTF 2.0's metallic-roughness material (its `pbrMetallicRoughness` and the core textures),
// shaded with the split sum (shaders/ibl.frag METALLIC_ROUGHNESS; common/brdf.hpp's BRDF): the
// Lambertian diffuse of base x (1 - metallic) from the irradiance, the GGX specular of
// F0 = mix(0.04, base, metallic) from the room's GGX chain (Renderer::set_ggx_chain) and the DFG
// table, with Filament's multiple-scattering compensation. The base colour texture is the
// Material's `albedo` (sRGB), the normal texture its `normal_map` (normal_strength its scale).
struct MetallicRoughness {
  glm::vec4 base_colour{1.0f};  // linear RGBA factor
  float metallic = 1.0f, roughness = 1.0f;  // factors (glTF's defaults); perceptual roughness
  // B: metallic, G: roughness (linear), times the factors.
  std::shared_ptr<const TextureImage> metallic_roughness;
  // R: the ambient occlusion of the indirect light (linear): 1 + strength x (R - 1).
  std::shared_ptr<const TextureImage> occlusion;
  float occlusion_strength = 1.0f;
  glm::vec3 emissive{0.0f};  // linear radiance factor
  std::shared_ptr<const TextureImage> emissive_map;  // sRGB, times `emissive`
  // MASK: fragments whose alpha (base colour's) is below the cutoff are not drawn.
  bool alpha_mask = false;
  float alpha_cutoff = 0.5f;
  // BLEND: the alpha is the surface's coverage: it is drawn over what is behind it (the opaque
  // virtual parts, else the camera frame), after the opaque parts (Renderer::draw).
  bool alpha_blend = false;
};

struct Material {
  // Set: the material is glTF metallic-roughness (kd, ks, shininess, light_map and the glass
  // fields are not used); unset: the thesis's Phong material.
  std::optional<MetallicRoughness> pbr;
  glm::vec3 kd{0.8f};         // diffuse reflectance (multiplied by the albedo map, if any)
  glm::vec3 ks{0.0f};         // specular reflectance
  float shininess = 32.0f;    // Phong exponent: picks (interpolates) the reflection map
  bool double_sided = false;  // false: back faces are culled (closed meshes, glTF's default)
  // Diffuse colour texture (usually srgb = true), multiplies kd.
  std::shared_ptr<const TextureImage> albedo;
  // Tangent-space normal map, OpenGL convention (+Y up the image), eq. 5.1 encoding
  // n_t = n / 2 + 0.5; thesis Alg. 5.3/5.4. Needs a mesh with uvs (ignored otherwise).
  std::shared_ptr<const TextureImage> normal_map;
  float normal_strength = 1.0f;  // scales the map's tangent-plane tilt (0 = flat)
  // Light map (e.g. ambient occlusion), linear RGB in [0, 1], multiplies the diffuse irradiance
  // only (thesis Alg. 5.2). Sampled with TEXCOORD_0.
  std::shared_ptr<const TextureImage> light_map;
  // Glass (dissertation §5.5): the share of the light refracted through the object that gets
  // through it, per channel (its tint); 0 = opaque. A transmissive material's reflection is
  // the Fresnel term of `ior` times the reflection map of `shininess` (ks is not used), and
  // what shows through it is the environment or the live camera frame (Renderer's
  // set_refraction). It is drawn from the front only: its far surface is the ellipsoid
  // inscribed in the mesh's bounds (exact for a sphere, a thickness for anything else).
  glm::vec3 transmission{0.0f};
  float ior = 1.5f;  // index of refraction (crown glass 1.5, water 1.33, diamond 2.42)

  bool transmissive() const { return !pbr && transmission != glm::vec3(0.0f); }
};

// Whether a draw with these materials (Renderer::draw's: the parts' and the fallback) shades
// anything metallic-roughness, which the room's GGX chain lights.
bool needs_ggx_chain(std::span<const Material> materials, const Material& fallback);

// Clear glass of an index of refraction, reflections as sharp as the shininess picks.
Material glass(float ior = 1.5f, float shininess = 1280.0f);

// The page's materials by name: the Phong "plastic", "matte", "metal", "glass" (shininess up to
// `sharpest`, the sharpest reflection map there is) and the metallic-roughness "gold" and
// "porcelain"; std::invalid_argument otherwise.
Material preset_material(std::string_view name, float sharpest = 640.0f);

}  // namespace arlight::render
