// Writing binary glTF (.glb): the mesh's arrays as accessors, one primitive per part, the
// metallic-roughness materials with their textures as PNG (stb_image_write), and arlight's baked
// occlusion as application attributes and extras (mesh.hpp). The reader is gltf.cpp.
#include <stb_image_write.h>

#include <algorithm>
#include <glm/gtc/type_ptr.hpp>
#include <map>
#include <nlohmann/json.hpp>
#include <stdexcept>

#include "arlight/render/gltf.hpp"

namespace arlight::render {

namespace {

using json = nlohmann::json;

constexpr std::uint32_t kGlbMagic = 0x46546C67;  // "glTF"
constexpr std::uint32_t kChunkJson = 0x4E4F534A;
constexpr std::uint32_t kChunkBin = 0x004E4942;

std::vector<std::uint8_t> encode_png(const TextureImage& image) {
  if (image.u8.empty() || image.u8.size() != std::size_t(image.width) * image.height * image.channels)
    throw std::invalid_argument("encode_glb: textures must be 8-bit images (float ones are not written)");
  std::vector<std::uint8_t> png;
  auto append = [](void* context, void* data, int size) {
    auto* out = static_cast<std::vector<std::uint8_t>*>(context);
    out->insert(out->end(), static_cast<std::uint8_t*>(data), static_cast<std::uint8_t*>(data) + size);
  };
  if (!stbi_write_png_to_func(append, &png, image.width, image.height, image.channels,
                              image.u8.data(), image.width * image.channels))
    throw std::runtime_error("encode_glb: PNG encoding failed");
  return png;
}

}  // namespace

std::vector<std::uint8_t> encode_glb(const GltfModel& model) {
  return encode_glb(model.mesh, model.materials, model.material_names);
}

std::vector<std::uint8_t> encode_glb(const Mesh& mesh, std::span<const Material> materials,
                                     std::span<const std::string> material_names) {
  const std::size_t n = mesh.positions.size();
  if (n == 0 || mesh.normals.size() != n || (!mesh.uvs.empty() && mesh.uvs.size() != n) ||
      (!mesh.occlusion.empty() && mesh.occlusion.size() != n) ||
      (!mesh.transfer.empty() && mesh.transfer.size() != n * kTransferCoefficients) ||
      mesh.indices.size() % 3 != 0)
    throw std::invalid_argument(
        "encode_glb: positions, normals (and uvs, occlusion, transfer) must match, whole "
        "triangles");
  for (const std::uint32_t i : mesh.indices)
    if (i >= n) throw std::invalid_argument("encode_glb: an index beyond the vertices");
  for (const MeshPart& part : mesh.parts)
    if (part.first_index % 3 != 0 || part.index_count % 3 != 0 ||
        std::size_t(part.first_index) + part.index_count > mesh.indices.size() ||
        (!materials.empty() && part.material >= int(materials.size())))
      throw std::invalid_argument(
          "encode_glb: a part beyond the indices, not whole triangles, or its material missing");
  // The binary chunk: positions, normals, uvs, indices, each 4-byte aligned (they are).
  std::vector<std::uint8_t> bin;
  json views = json::array(), accessors = json::array();
  auto append = [&](const void* data, std::size_t bytes, int target, int component,
                    std::size_t count, const char* type) {
    json view = {{"buffer", 0}, {"byteOffset", bin.size()}, {"byteLength", bytes}};
    if (target) view["target"] = target;  // 0: not vertex or index data
    views.push_back(std::move(view));
    accessors.push_back({{"bufferView", views.size() - 1}, {"componentType", component},
                         {"count", count}, {"type", type}});
    const auto* p = static_cast<const std::uint8_t*>(data);
    bin.insert(bin.end(), p, p + bytes);
    return accessors.size() - 1;
  };
  constexpr int kArrayBuffer = 34962, kElementArrayBuffer = 34963, kFloat = 5126, kUint = 5125;
  json attributes;
  attributes["POSITION"] = append(mesh.positions.data(), n * sizeof(glm::vec3), kArrayBuffer, kFloat, n, "VEC3");
  Bounds b;
  b.min = b.max = mesh.positions[0];
  for (const glm::vec3& p : mesh.positions) b.min = glm::min(b.min, p), b.max = glm::max(b.max, p);
  accessors[attributes["POSITION"].get<std::size_t>()]["min"] = {b.min.x, b.min.y, b.min.z};
  accessors[attributes["POSITION"].get<std::size_t>()]["max"] = {b.max.x, b.max.y, b.max.z};
  attributes["NORMAL"] = append(mesh.normals.data(), n * sizeof(glm::vec3), kArrayBuffer, kFloat, n, "VEC3");
  if (!mesh.uvs.empty())
    attributes["TEXCOORD_0"] = append(mesh.uvs.data(), n * sizeof(glm::vec2), kArrayBuffer, kFloat, n, "VEC2");
  // The tangents normal maps were made against (glTF: a viewer that generates its own may differ).
  if (!mesh.uvs.empty() && mesh.tangents.size() == n)
    attributes["TANGENT"] = append(mesh.tangents.data(), n * sizeof(glm::vec4), kArrayBuffer, kFloat, n, "VEC4");
  if (!mesh.occlusion.empty())  // glTF's application-specific attributes start with '_'
    attributes["_OCCLUSION"] =
        append(mesh.occlusion.data(), n * sizeof(glm::vec4), kArrayBuffer, kFloat, n, "VEC4");
  if (!mesh.transfer.empty()) {
    // Three VEC3 attributes (glTF has no 9-vector): coefficients 0-2, 3-5, 6-8.
    std::vector<glm::vec3> part(n);
    for (int k = 0; k < 3; ++k) {
      for (std::size_t i = 0; i < n; ++i)
        part[i] = glm::make_vec3(&mesh.transfer[i * kTransferCoefficients + 3 * std::size_t(k)]);
      attributes["_SH_TRANSFER_" + std::to_string(k)] =
          append(part.data(), n * sizeof(glm::vec3), kArrayBuffer, kFloat, n, "VEC3");
    }
  }
  // One primitive per part (the whole mesh without parts), each with its indices and material.
  json primitives = json::array();
  const std::vector<MeshPart> parts =
      mesh.parts.empty() ? std::vector<MeshPart>{{0, std::uint32_t(mesh.indices.size()), -1}} : mesh.parts;
  for (const MeshPart& part : parts) {
    json prim = {{"attributes", attributes},
                 {"indices", append(mesh.indices.data() + part.first_index, part.index_count * 4,
                                    kElementArrayBuffer, kUint, part.index_count, "SCALAR")},
                 {"mode", 4}};
    if (part.material >= 0 && !materials.empty()) prim["material"] = part.material;
    primitives.push_back(std::move(prim));
  }
  json images = json::array(), textures = json::array(), gltf_materials = json::array();
  std::map<const TextureImage*, std::size_t> texture_of;
  // A texture reference {index}: each image once, as a PNG in the binary chunk.
  auto texture = [&](const std::shared_ptr<const TextureImage>& image) {
    auto [it, added] = texture_of.try_emplace(image.get(), textures.size());
    if (added) {
      const std::vector<std::uint8_t> png = encode_png(*image);
      views.push_back({{"buffer", 0}, {"byteOffset", bin.size()}, {"byteLength", png.size()}});
      bin.insert(bin.end(), png.begin(), png.end());
      bin.resize((bin.size() + 3) / 4 * 4, 0);  // the next view 4-byte aligned
      images.push_back({{"bufferView", views.size() - 1}, {"mimeType", "image/png"}});
      textures.push_back({{"source", images.size() - 1}});
    }
    return json{{"index", it->second}};
  };
  for (std::size_t i = 0; i < materials.size(); ++i) {
    const Material& m = materials[i];
    if (!m.pbr)
      throw std::invalid_argument("encode_glb: only metallic-roughness materials are written");
    const MetallicRoughness& p = *m.pbr;
    json pbr = {{"baseColorFactor", {p.base_colour.r, p.base_colour.g, p.base_colour.b, p.base_colour.a}},
                {"metallicFactor", p.metallic},
                {"roughnessFactor", p.roughness}};
    if (m.albedo) pbr["baseColorTexture"] = texture(m.albedo);
    if (p.metallic_roughness) pbr["metallicRoughnessTexture"] = texture(p.metallic_roughness);
    json g = {{"pbrMetallicRoughness", pbr}, {"doubleSided", m.double_sided}};
    if (m.normal_map) g["normalTexture"] = texture(m.normal_map), g["normalTexture"]["scale"] = m.normal_strength;
    if (p.occlusion)
      g["occlusionTexture"] = texture(p.occlusion), g["occlusionTexture"]["strength"] = p.occlusion_strength;
    const float emissive = std::max({p.emissive.r, p.emissive.g, p.emissive.b});
    if (emissive > 0.0f) {
      // Factors above 1 as KHR_materials_emissive_strength, as glTF asks.
      const float strength = std::max(emissive, 1.0f);
      const glm::vec3 e = p.emissive / strength;
      g["emissiveFactor"] = {e.r, e.g, e.b};
      if (strength > 1.0f)
        g["extensions"]["KHR_materials_emissive_strength"] = {{"emissiveStrength", strength}};
    }
    if (p.emissive_map) g["emissiveTexture"] = texture(p.emissive_map);
    if (p.alpha_mask) g["alphaMode"] = "MASK", g["alphaCutoff"] = p.alpha_cutoff;
    if (p.alpha_blend) g["alphaMode"] = "BLEND";
    if (i < material_names.size() && !material_names[i].empty()) g["name"] = material_names[i];
    gltf_materials.push_back(std::move(g));
  }
  json extras = json::object();
  if (!mesh.ground.empty()) {
    const GroundOcclusion& g = mesh.ground;
    if (g.occluded.size() != std::size_t(g.size) * std::size_t(g.size))
      throw std::invalid_argument("encode_glb: the ground occlusion is not size x size");
    const std::size_t a = append(g.occluded.data(), g.occluded.size() * sizeof(float), 0, kFloat,
                                 g.occluded.size(), "SCALAR");
    extras["arlight_ground"] = {{"min", {g.min.x, g.min.y}},
                                {"max", {g.max.x, g.max.y}},
                                {"size", g.size},
                                {"accessor", a}};
    if (!g.hidden_transfer.empty()) {
      if (g.hidden_transfer.size() != g.occluded.size() * kTransferCoefficients)
        throw std::invalid_argument("encode_glb: the ground's transfer is not size x size x 9");
      extras["arlight_ground"]["transfer_accessor"] =
          append(g.hidden_transfer.data(), g.hidden_transfer.size() * sizeof(float), 0, kFloat,
                 g.hidden_transfer.size(), "SCALAR");
    }
  }
  json doc = {
      {"asset", {{"version", "2.0"}, {"generator", "arlight"}}},
      {"scene", 0},
      {"scenes", json::array({{{"nodes", {0}}}})},
      {"nodes", json::array({{{"mesh", 0}}})},
      {"meshes", json::array({{{"primitives", primitives}}})},
      {"buffers", json::array({{{"byteLength", bin.size()}}})},
      {"bufferViews", views},
      {"accessors", accessors}};
  if (!extras.empty()) doc["extras"] = std::move(extras);
  if (!gltf_materials.empty()) doc["materials"] = std::move(gltf_materials);
  if (!textures.empty()) doc["textures"] = std::move(textures), doc["images"] = std::move(images);
  bool emissive_strength = false;
  for (const json& g : doc.value("materials", json::array()))
    emissive_strength |= g.contains("extensions");
  if (emissive_strength) doc["extensionsUsed"] = {"KHR_materials_emissive_strength"};
  std::string text = doc.dump();
  text.resize((text.size() + 3) / 4 * 4, ' ');  // chunks are 4-byte aligned
  bin.resize((bin.size() + 3) / 4 * 4, 0);
  std::vector<std::uint8_t> out;
  auto put32 = [&](std::uint32_t v) {
    for (int i = 0; i < 4; ++i) out.push_back(std::uint8_t(v >> (8 * i)));
  };
  put32(kGlbMagic), put32(2), put32(std::uint32_t(12 + 8 + text.size() + 8 + bin.size()));
  put32(std::uint32_t(text.size())), put32(kChunkJson);
  out.insert(out.end(), text.begin(), text.end());
  put32(std::uint32_t(bin.size())), put32(kChunkBin);
  out.insert(out.end(), bin.begin(), bin.end());
  return out;
}

}  // namespace arlight::render
