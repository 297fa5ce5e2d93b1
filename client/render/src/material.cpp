#include "arlight/render/material.hpp"

#include <algorithm>
#include <stdexcept>
#include <string>

namespace arlight::render {

std::shared_ptr<const TextureImage> make_texture(const ImageU8View& rgb, bool srgb) {
  if (!rgb.data || rgb.width < 1 || rgb.height < 1 ||
      !(rgb.channels == 1 || rgb.channels == 3 || rgb.channels == 4))
    throw std::invalid_argument("texture must be a non-empty 8-bit image of 1, 3 or 4 channels");
  auto t = std::make_shared<TextureImage>();
  t->width = rgb.width, t->height = rgb.height, t->channels = rgb.channels, t->srgb = srgb;
  const std::size_t row = std::size_t(rgb.width) * rgb.channels;
  t->u8.resize(row * rgb.height);
  for (int y = 0; y < rgb.height; ++y)
    std::copy(rgb.row(y), rgb.row(y) + row, t->u8.begin() + std::ptrdiff_t(row * y));
  return t;
}

std::shared_ptr<const TextureImage> make_texture(int width, int height, int channels,
                                                 std::vector<float> linear) {
  if (width < 1 || height < 1 || !(channels == 1 || channels == 3) ||
      linear.size() != std::size_t(width) * height * channels)
    throw std::invalid_argument("float texture must hold width * height * (1 or 3) values, " +
                                std::to_string(linear.size()) + " given");
  auto t = std::make_shared<TextureImage>();
  t->width = width, t->height = height, t->channels = channels;
  t->f32 = std::move(linear);
  return t;
}

bool needs_ggx_chain(std::span<const Material> materials, const Material& fallback) {
  return fallback.pbr ||
         std::any_of(materials.begin(), materials.end(), [](const Material& m) { return m.pbr; });
}

Material preset_material(std::string_view name, float sharpest) {
  Material m;
  if (name == "plastic") {
    m.kd = glm::vec3(0.55f, 0.1f, 0.08f), m.ks = glm::vec3(0.25f), m.shininess = 160;
  } else if (name == "metal") {
    m.kd = glm::vec3(0.05f), m.ks = glm::vec3(0.9f, 0.8f, 0.6f), m.shininess = sharpest;
  } else if (name == "matte") {
    m.kd = glm::vec3(0.8f), m.ks = glm::vec3(0.0f), m.shininess = 10;
  } else if (name == "glass") {
    m = glass(1.5f, sharpest);
  } else if (name == "gold" || name == "porcelain") {
    // glTF metallic-roughness: gold's F0 (linear sRGB, Filament's table), a glazed white.
    m.pbr = MetallicRoughness{};
    const bool gold = name == "gold";
    m.pbr->base_colour = gold ? glm::vec4(1.0f, 0.782f, 0.344f, 1.0f) : glm::vec4(0.9f, 0.9f, 0.86f, 1.0f);
    m.pbr->metallic = gold ? 1.0f : 0.0f;
    m.pbr->roughness = gold ? 0.3f : 0.15f;
  } else {
    throw std::invalid_argument("material '" + std::string(name) +
                                "': matte, plastic, metal, glass, gold or porcelain");
  }
  return m;
}

Material glass(float ior, float shininess) {
  if (!(ior >= 1.0f && ior <= 3.0f))
    throw std::invalid_argument("glass: the index of refraction must be in [1, 3], not " +
                                std::to_string(ior));
  if (!(shininess >= 1.0f)) throw std::invalid_argument("glass: shininess must be >= 1");
  Material m;
  m.kd = glm::vec3(0.0f), m.ks = glm::vec3(0.0f);
  m.shininess = shininess;
  m.transmission = glm::vec3(1.0f);
  m.ior = ior;
  return m;
}

}  // namespace arlight::render
