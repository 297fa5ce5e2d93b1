// Internal: a glTF document's materials as render::Material (metallic-roughness, its textures
// decoded with stb_image), with messages that name the material and field.
#pragma once

#include <glm/mat3x3.hpp>
#include <string>
#include <vector>

#include "arlight/render/material.hpp"
#include "gltf_document.hpp"

namespace arlight::render::gltf_detail {

// The texture coordinates a material's textures read: one set and one KHR_texture_transform
// for all its textures (what the renderer's one uv attribute gives), applied to the uvs of
// the primitives that use it.
struct MaterialUv {
  bool textured = false;
  int set = 0;
  glm::mat3 transform{1.0f};
};

struct GltfMaterials {
  std::vector<MaterialUv> uv;  // one per glTF material, always
  // With `decode` (else empty): the materials, their names, and what is read but not drawn.
  std::vector<Material> materials;
  std::vector<std::string> names, warnings;
};

// Every material of the document; throws InputError for a bad one. Textures are decoded only
// with `decode` (the geometry alone needs the uv sets and transforms).
GltfMaterials read_materials(const GltfDocument& doc, bool decode);

// "'<file>': material 2 'Body': ", the prefix of a material's messages.
std::string material_where(const GltfDocument& doc, std::size_t index);

}  // namespace arlight::render::gltf_detail
