// glTF 2.0 files: reading them (.glb, .gltf; through tinygltf, KHR_draco_mesh_compression
// decoded with libdraco) into a mesh and its metallic-roughness materials, and writing .glb.
#pragma once

#include <cstdint>
#include <filesystem>
#include <span>
#include <string>
#include <vector>

#include "arlight/render/material.hpp"
#include "arlight/render/mesh.hpp"

namespace arlight::render {

// A glTF scene as the renderer draws it: every triangle primitive in one mesh (its parts, in
// order, say which material each uses) and the file's materials.
struct GltfModel {
  Mesh mesh;
  // One per glTF material, in the file's order (MeshPart::material indexes them): metallic-
  // roughness (Material::pbr) with the base colour (sRGB; the Material's albedo), metal/rough
  // (B/G), normal (+ scale), occlusion (+ strength) and emissive (sRGB) textures, alphaMode
  // OPAQUE / MASK (+ cutoff) / BLEND, doubleSided, KHR_materials_emissive_strength. A material's
  // textures must read one TEXCOORD set (0 or 1) with one KHR_texture_transform: both are applied
  // to the uvs of the primitives that use it (the renderer has one uv attribute).
  std::vector<Material> materials;
  std::vector<std::string> material_names;  // as the file names them ("" when unnamed)
  // What was read but is not drawn as the file asks (material extensions it does not know are
  // ignored), each naming the material and extension.
  std::vector<std::string> warnings;
};

// Loads every triangle primitive of the default scene (or of all root nodes) of a glTF 2.0 file,
// node transforms applied, and the materials. Positions, normals (computed when absent), the
// uvs its material reads (float or normalized integers) and indices (u8/u16/u32) are read;
// KHR_draco_mesh_compression primitives are decoded with libdraco; PNG and JPEG textures with
// stb_image. Every problem (bad magic, chunk beyond the file, accessor out of range, Draco
// decode failure, a material factor out of range, an image that does not decode, ...) throws
// arlight::InputError naming the file and what is wrong: the material and field where one is.
GltfModel load_gltf_model(const std::filesystem::path& path);
// The same from a file's bytes (`name` for messages); buffers and images must be inside (GLB or
// data: URIs).
GltfModel load_gltf_model(std::span<const std::uint8_t> bytes, const std::string& name);
// The geometry alone (parts keep their material indices; no texture is decoded).
Mesh load_gltf(const std::filesystem::path& path);
Mesh load_gltf(std::span<const std::uint8_t> bytes, const std::string& name);

// A binary glTF (.glb) of the mesh: positions, normals, uvs when present, uint32 indices, one
// node, one primitive per part, no compression (what the browser client loads: its build has no
// Draco); with `materials` (metallic-roughness only, indexed by the parts), their factors and
// 8-bit textures as PNG; without, the parts are written without materials. Throws std::invalid_argument for a mesh whose arrays disagree.
std::vector<std::uint8_t> encode_glb(const Mesh& mesh, std::span<const Material> materials = {},
                                     std::span<const std::string> material_names = {});
// The model with its materials and their names.
std::vector<std::uint8_t> encode_glb(const GltfModel& model);

}  // namespace arlight::render
