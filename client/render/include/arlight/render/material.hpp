// Phong materials for image-based lighting (thesis §5.3): kd, ks, shininess, and optional
// albedo, tangent-space normal and light maps.
#pragma once

#include <filesystem>
#include <glm/vec3.hpp>
#include <memory>
#include <opencv2/core/mat.hpp>

namespace arlight::render {

// A texture image as an OpenCV matrix: CV_8UC1/3/4 in OpenCV's channel order (gray, BGR, BGRA)
// or CV_32FC1/3 (gray, BGR) in linear float. Row 0 is the top of the image (uv v = 0).
// `srgb` says whether 8-bit values are sRGB-encoded (albedo photos) or linear (normal maps,
// light maps); float images are always linear. The renderer uploads each TextureImage once and
// keeps it while the shared_ptr lives.
struct TextureImage {
  cv::Mat pixels;
  bool srgb = false;
};

// Reads an image file with OpenCV (PNG, JPEG, WebP, ...); throws arlight::InputError naming the
// file when it cannot be read.
std::shared_ptr<const TextureImage> load_texture(const std::filesystem::path& path, bool srgb);
std::shared_ptr<const TextureImage> make_texture(cv::Mat pixels, bool srgb);

struct Material {
  glm::vec3 kd{0.8f};      // diffuse reflectance (multiplied by the albedo map, if any)
  glm::vec3 ks{0.0f};      // specular reflectance
  float shininess = 32.0f;  // Phong exponent: picks (interpolates) the reflection map
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
};

}  // namespace arlight::render
