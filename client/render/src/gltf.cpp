// glTF 2.0 reading (.glb and .gltf) through tinygltf: the document, its buffers (GLB chunk, data:
// URIs, files beside the model) and its images' bytes; arlight reads the accessors (each one
// bounds-checked here: tinygltf leaves that to its caller), decodes KHR_draco_mesh_compression
// with libdraco and the PNG / JPEG textures with stb_image, and turns the materials into
// render::Material. Problems throw InputError("'<file>': <what>"), naming the material and field
// where one is at fault. ARLIGHT_NO_DRACO (the browser client's WebAssembly build: no libdraco
// there) leaves Draco out: such models are refused by name, and `arlight-model convert`
// re-encodes them without it.
#ifndef ARLIGHT_NO_DRACO
#include <draco/compression/decode.h>
#endif
#include <stb_image.h>
#include "tiny_gltf.hpp"

#include <cmath>
#include <cstring>
#include <fstream>
#include <glm/gtc/matrix_inverse.hpp>
#include <glm/gtc/quaternion.hpp>
#include <glm/gtc/type_ptr.hpp>
#include <map>
#include <nlohmann/json.hpp>
#include <span>
#include <sstream>
#include <string>

#include "arlight/common/error.hpp"
#include "arlight/common/sh.hpp"
#include "arlight/render/gltf.hpp"

namespace arlight::render {

namespace {

using json = nlohmann::json;

constexpr std::uint32_t kGlbMagic = 0x46546C67;  // "glTF"
constexpr std::uint32_t kChunkJson = 0x4E4F534A;
constexpr int kMaxTextureSide = 8192;

std::vector<std::uint8_t> read_file(const std::filesystem::path& path, const std::string& where) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(where + "cannot open the file");
  in.seekg(0, std::ios::end);
  const auto size = std::streamoff(in.tellg());
  if (size < 0) throw InputError(where + "cannot read the file");
  in.seekg(0);
  std::vector<std::uint8_t> data(static_cast<std::size_t>(size));
  if (size > 0 && !in.read(reinterpret_cast<char*>(data.data()), size))
    throw InputError(where + "cannot read the file");
  return data;
}

// "'<path>': ", the prefix of every message (built by appending: GCC 12 warns falsely about
// "'" + std::string).
std::string where_prefix(const std::filesystem::path& path) {
  std::string s = "'";
  s.append(path.string()).append("': ");
  return s;
}

std::uint32_t u32(const std::uint8_t* p) {
  std::uint32_t v;
  std::memcpy(&v, p, 4);
  return v;  // glTF is little-endian, like every platform we build for
}

// The GLB container (header, chunk lengths) checked before tinygltf reads it, so that a cut or
// lying file gets a message that says which length is wrong.
void check_glb(std::span<const std::uint8_t> file, const std::string& where) {
  if (file.size() < 12) throw InputError(where + "truncated GLB header");
  const std::uint32_t version = u32(file.data() + 4), length = u32(file.data() + 8);
  if (version != 2) throw InputError(where + "GLB version " + std::to_string(version) + ", need 2");
  if (length > file.size())
    throw InputError(where + "GLB header says " + std::to_string(length) +
                     " bytes but the file has " + std::to_string(file.size()));
  std::size_t pos = 12;
  bool have_json = false;
  while (pos + 8 <= length) {
    const std::uint32_t chunk_len = u32(file.data() + pos), type = u32(file.data() + pos + 4);
    if (std::uint64_t(pos) + 8 + chunk_len > length)
      throw InputError(where + "chunk at byte " + std::to_string(pos) + " (length " +
                       std::to_string(chunk_len) + ") extends beyond the file");
    if (type == kChunkJson) have_json = true;
    pos += 8 + std::size_t(chunk_len);
  }
  if (!have_json) throw InputError(where + "GLB has no JSON chunk");
}

// The transfers of unoccluded vertices: the clamped cosine around each normal (sh_cosine_lobe).
std::vector<float> open_transfers(std::span<const glm::vec3> normals) {
  std::vector<float> out;
  out.reserve(normals.size() * kTransferCoefficients);
  for (const glm::vec3& n : normals)
    for (const double t : sh_cosine_lobe(glm::dvec3(n), 3)) out.push_back(float(t));
  return out;
}

// Turns transfers (9 per vertex) with a node's normal matrix: T'(w) = T(R^T w), R the nearest
// rotation (or reflection) to the normal matrix's direction (its columns made orthonormal).
void rotate_transfer(std::span<float> transfer, const glm::dmat3& normal_matrix) {
  glm::dmat3 r = normal_matrix;
  r[0] = glm::normalize(r[0]);
  r[1] = glm::normalize(r[1] - glm::dot(r[1], r[0]) * r[0]);
  r[2] = glm::normalize(r[2] - glm::dot(r[2], r[0]) * r[0] - glm::dot(r[2], r[1]) * r[1]);
  double off = 0;
  for (int c = 0; c < 3; ++c)
    for (int k = 0; k < 3; ++k) off = std::max(off, std::abs(r[c][k] - (c == k ? 1.0 : 0.0)));
  if (off < 1e-9) return;
  // The 9 x 9 matrix once: column j is the rotated expansion of the j-th basis function.
  double m[kTransferCoefficients][kTransferCoefficients];
  for (int j = 0; j < kTransferCoefficients; ++j) {
    ShCoeffs e(3);
    e.c[std::size_t(j)].x = 1.0;
    const ShCoeffs col = sh_rotate(e, glm::transpose(r));
    for (int k = 0; k < kTransferCoefficients; ++k) m[k][j] = col.c[std::size_t(k)].x;
  }
  for (std::size_t i = 0; i + kTransferCoefficients <= transfer.size();
       i += kTransferCoefficients) {
    double t[kTransferCoefficients];
    for (int k = 0; k < kTransferCoefficients; ++k) t[k] = transfer[i + std::size_t(k)];
    for (int k = 0; k < kTransferCoefficients; ++k) {
      double v = 0;
      for (int j = 0; j < kTransferCoefficients; ++j) v += m[k][j] * t[j];
      transfer[i + std::size_t(k)] = float(v);
    }
  }
}

// tinygltf 2.7 refuses a primitive whose indices accessor has no bufferView, which is how
// KHR_draco_mesh_compression files are written (the indices are in the Draco stream; tinygltf's
// own Draco option is not built). Such primitives lose "indices" before tinygltf reads the
// document (the JSON rewritten, a GLB's other chunks as they were); the counts those accessors
// gave, by (mesh, primitive), are kept to check the decoded meshes against.
using DracoIndexCounts = std::map<std::pair<std::size_t, std::size_t>, std::size_t>;
std::vector<std::uint8_t> draco_indices_moved(std::vector<std::uint8_t> bytes, bool glb,
                                              DracoIndexCounts& counts, const std::string& where) {
  const std::size_t json_at = glb ? 20 : 0;
  const std::size_t json_length = glb ? u32(bytes.data() + 12) : bytes.size();
  if (glb && (u32(bytes.data() + 16) != kChunkJson || json_at + json_length > bytes.size()))
    throw InputError(where + "the GLB's first chunk is not its JSON");
  const std::string_view text(reinterpret_cast<const char*>(bytes.data()) + json_at, json_length);
  if (text.find("KHR_draco_mesh_compression") == std::string_view::npos) return bytes;
  json doc = json::parse(text, nullptr, false);
  if (doc.is_discarded() || !doc.is_object() || !doc.contains("meshes") || !doc["meshes"].is_array())
    return bytes;  // tinygltf reports what is wrong
  const json accessors = doc.value("accessors", json::array());
  bool changed = false;
  for (std::size_t m = 0; m < doc["meshes"].size(); ++m) {
    json& primitives = doc["meshes"][m]["primitives"];
    if (!primitives.is_array()) continue;
    for (std::size_t p = 0; p < primitives.size(); ++p) {
      json& prim = primitives[p];
      if (!prim.is_object() || !prim.contains("indices") || !prim["indices"].is_number_unsigned() ||
          !prim.value("extensions", json::object()).contains("KHR_draco_mesh_compression"))
        continue;
      const std::size_t a = prim["indices"].get<std::size_t>();
      if (!accessors.is_array() || a >= accessors.size() || !accessors[a].is_object() ||
          accessors[a].contains("bufferView"))
        continue;
      counts[{m, p}] = accessors[a].value("count", std::size_t(0));
      prim.erase("indices");
      changed = true;
    }
  }
  if (!changed) return bytes;
  std::string rewritten = doc.dump();
  if (!glb) return {rewritten.begin(), rewritten.end()};
  rewritten.resize((rewritten.size() + 3) / 4 * 4, ' ');
  std::vector<std::uint8_t> out(bytes.begin(), bytes.begin() + 12);
  auto put32 = [&](std::uint32_t v) {
    for (int i = 0; i < 4; ++i) out.push_back(std::uint8_t(v >> (8 * i)));
  };
  put32(std::uint32_t(rewritten.size())), put32(kChunkJson);
  out.insert(out.end(), rewritten.begin(), rewritten.end());
  out.insert(out.end(), bytes.begin() + std::ptrdiff_t(json_at + json_length),
             bytes.begin() + std::ptrdiff_t(u32(bytes.data() + 8)));
  const auto total = std::uint32_t(out.size());
  std::memcpy(out.data() + 8, &total, 4);
  return out;
}

// tinygltf hands over each image's bytes as the file holds them (PNG, JPEG): they are decoded
// when a material uses them, so a bad one is reported with the material and field. `model` is
// the one being read: tinygltf 2.7 passes an image's bufferView without checking that it lies
// inside its buffer (the fuzzer found it), so that is checked here before a byte is read.
bool keep_encoded_image(tinygltf::Image* image, const int index, std::string* err, std::string*,
                        int, int, const unsigned char* bytes, int size, void* model) {
  if (image->bufferView >= 0) {
    const auto& m = *static_cast<const tinygltf::Model*>(model);
    const tinygltf::BufferView& view = m.bufferViews.at(std::size_t(image->bufferView));
    const std::size_t buffer = m.buffers.at(std::size_t(view.buffer)).data.size();
    if (view.byteOffset > buffer || view.byteLength > buffer - view.byteOffset || size < 0) {
      if (err)
        *err += "image " + std::to_string(index) + ": its bufferView " +
                std::to_string(image->bufferView) + " reaches beyond its buffer\n";
      return false;
    }
  }
  image->image.assign(bytes, bytes + size);
  image->as_is = true;
  return true;
}

// The files a .gltf names (buffers, images) beside it; a model read from memory has none.
struct FileAccess {
  bool on_disk = false;
};
bool file_exists(const std::string& path, void* user) {
  return static_cast<FileAccess*>(user)->on_disk && std::filesystem::is_regular_file(path);
}
std::string expand_path(const std::string& path, void*) { return path; }
bool read_whole_file(std::vector<unsigned char>* out, std::string* err, const std::string& path,
                     void* user) {
  if (!static_cast<FileAccess*>(user)->on_disk) {
    if (err) *err += "'" + path + "' is a separate file (a model from memory must hold its data)\n";
    return false;
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    if (err) *err += "cannot open '" + path + "'\n";
    return false;
  }
  out->assign(std::istreambuf_iterator<char>(in), {});
  return true;
}
bool write_whole_file(std::string* err, const std::string&, const std::vector<unsigned char>&,
                      void*) {
  if (err) *err += "arlight's glTF reader writes no files\n";
  return false;
}

// A number as a file would write it (1.5, not 1.500000).
std::string number(double v) {
  std::ostringstream out;
  out << v;
  return out.str();
}

// KHR_texture_transform as a 3 x 3 matrix on (u, v, 1): translation x rotation x scale, the
// extension's order and sign convention.
glm::mat3 texture_transform(const json& t) {
  const auto offset = t.value("offset", std::vector<float>{0.0f, 0.0f});
  const auto scale = t.value("scale", std::vector<float>{1.0f, 1.0f});
  const float rotation = t.value("rotation", 0.0f);
  if (offset.size() != 2 || scale.size() != 2 || !std::isfinite(rotation) ||
      !std::isfinite(offset[0] + offset[1] + scale[0] + scale[1]))
    throw std::invalid_argument("offset and scale must be 2 finite numbers, rotation finite");
  const float c = std::cos(rotation), s = std::sin(rotation);
  // Column-major: u' = c sx u + s sy v + ox, v' = -s sx u + c sy v + oy.
  return glm::mat3(glm::vec3(c * scale[0], -s * scale[0], 0.0f),
                   glm::vec3(s * scale[1], c * scale[1], 0.0f),
                   glm::vec3(offset[0], offset[1], 1.0f));
}

class GltfReader {
 public:
  // `name` appears in messages; with `on_disk`, buffers and images may be files beside it.
  GltfReader(const std::vector<std::uint8_t>& bytes, const std::filesystem::path& name,
             bool on_disk)
      : where_(where_prefix(name)) {
    files_.on_disk = on_disk;
    tinygltf::TinyGLTF loader;
    loader.SetImageLoader(&keep_encoded_image, &model_);
    loader.SetFsCallbacks(
        tinygltf::FsCallbacks{&file_exists, &expand_path, &read_whole_file, &write_whole_file, &files_});
    loader.SetStoreOriginalJSONForExtrasAndExtensions(true);
    const std::string base = on_disk ? name.parent_path().string() : std::string();
    std::string err, warn;
    bool ok = false;
    if (bytes.size() >= 4 && u32(bytes.data()) == kGlbMagic) {
      check_glb(bytes, where_);
      const std::vector<std::uint8_t> doc = draco_indices_moved(bytes, true, draco_indices_, where_);
      ok = loader.LoadBinaryFromMemory(&model_, &err, &warn, doc.data(), unsigned(doc.size()), base);
    } else if (name.extension() == ".glb") {
      throw InputError(where_ + "bad magic: not a binary glTF (.glb) file");
    } else {
      const std::vector<std::uint8_t> doc = draco_indices_moved(bytes, false, draco_indices_, where_);
      ok = loader.LoadASCIIFromString(&model_, &err, &warn, reinterpret_cast<const char*>(doc.data()),
                                      unsigned(doc.size()), base);
    }
    while (!err.empty() && err.back() == '\n') err.pop_back();
    if (!ok) throw InputError(where_ + "invalid glTF: " + (err.empty() ? "unreadable" : err));
    if (model_.asset.version.rfind("2.", 0) != 0)
      throw InputError(where_ + "not glTF 2.0 (asset.version)");
    for (const std::string& e : model_.extensionsRequired)
      if (e != "KHR_draco_mesh_compression" && e != "KHR_texture_transform" &&
          e != "KHR_materials_emissive_strength")
        throw InputError(where_ + "unsupported required extension \"" + e + "\"");
  }

  GltfModel load(bool with_materials) {
    read_materials(with_materials);
    std::vector<int> roots;
    if (!model_.scenes.empty()) {
      const int scene = std::max(model_.defaultScene, 0);
      if (std::size_t(scene) >= model_.scenes.size())
        throw InputError(where_ + "scene index out of range");
      roots = model_.scenes[std::size_t(scene)].nodes;
    } else {
      std::vector<bool> child(model_.nodes.size(), false);
      for (const tinygltf::Node& n : model_.nodes)
        for (const int c : n.children)
          if (c >= 0 && std::size_t(c) < child.size()) child[std::size_t(c)] = true;
      for (std::size_t i = 0; i < child.size(); ++i)
        if (!child[i]) roots.push_back(int(i));
    }
    for (int r : roots) visit(r, glm::dmat4(1.0), 0);
    if (mesh_.positions.empty()) throw InputError(where_ + "no triangle meshes in the scene");
    compute_bounds(mesh_);
    // The file's tangents when every primitive gave them for the uvs as they are (no
    // KHR_texture_transform applied); else MikkTSpace-style ones from the uvs.
    if (has_uvs_ && !(file_tangents_ && mesh_.tangents.size() == mesh_.positions.size()))
      compute_tangents(mesh_);
    read_ground();
    GltfModel out;
    out.mesh = std::move(mesh_);
    if (with_materials) {
      out.materials = std::move(materials_);
      out.material_names = std::move(material_names_);
      out.warnings = std::move(warnings_);
    }
    return out;
  }

 private:
  // "material 2 'Body': ", the prefix of a material's messages.
  std::string material_where(std::size_t index) const {
    std::string s = where_ + "material " + std::to_string(index);
    if (!model_.materials[index].name.empty()) s.append(" '").append(model_.materials[index].name).append("'");
    return s + ": ";
  }

  static json parse_extensions(const std::string& text, const std::string& where) {
    if (text.empty()) return json::object();
    try {
      json j = json::parse(text);
      if (!j.is_object()) throw InputError(where + "extensions is not an object");
      return j;
    } catch (const json::exception& e) {
      throw InputError(where + "extensions: " + e.what());
    }
  }

  // The texture coordinates a material's textures read: one set and one KHR_texture_transform
  // for all its textures (what the renderer's one uv attribute gives), applied to the uvs of
  // the primitives that use it.
  struct MaterialUv {
    bool textured = false;
    int set = 0;
    glm::mat3 transform{1.0f};
  };

  void read_materials(bool decode) {
    for (std::size_t i = 0; i < model_.materials.size(); ++i) {
      MaterialUv uv;
      Material m = read_material(i, decode, uv);
      material_uv_.push_back(uv);
      if (decode) {
        materials_.push_back(std::move(m));
        material_names_.push_back(model_.materials[i].name);
      }
    }
  }

  Material read_material(std::size_t index, bool decode, MaterialUv& uv) {
    const tinygltf::Material& g = model_.materials[index];
    const std::string what = material_where(index);
    Material m;
    MetallicRoughness& pbr = m.pbr.emplace();
    const tinygltf::PbrMetallicRoughness& p = g.pbrMetallicRoughness;
    auto in_unit = [](double v) { return v >= 0.0 && v <= 1.0; };
    if (p.baseColorFactor.size() != 4 || !std::all_of(p.baseColorFactor.begin(), p.baseColorFactor.end(), in_unit))
      throw InputError(what + "baseColorFactor must be 4 numbers in [0, 1]");
    pbr.base_colour = glm::vec4(float(p.baseColorFactor[0]), float(p.baseColorFactor[1]),
                                float(p.baseColorFactor[2]), float(p.baseColorFactor[3]));
    if (!in_unit(p.metallicFactor))
      throw InputError(what + "metallicFactor " + number(p.metallicFactor) + " is outside [0, 1]");
    if (!in_unit(p.roughnessFactor))
      throw InputError(what + "roughnessFactor " + number(p.roughnessFactor) + " is outside [0, 1]");
    pbr.metallic = float(p.metallicFactor), pbr.roughness = float(p.roughnessFactor);
    if (g.emissiveFactor.size() != 3 || !std::all_of(g.emissiveFactor.begin(), g.emissiveFactor.end(), in_unit))
      throw InputError(what + "emissiveFactor must be 3 numbers in [0, 1]");
    pbr.emissive = glm::vec3(float(g.emissiveFactor[0]), float(g.emissiveFactor[1]), float(g.emissiveFactor[2]));
    const json ext = parse_extensions(g.extensions_json_string, what);
    for (const auto& [name, value] : ext.items()) {
      if (name == "KHR_materials_emissive_strength") {
        const json s = value.is_object() ? value.value("emissiveStrength", json(1.0)) : json();
        if (!s.is_number() || !(s.get<double>() >= 0.0) || !std::isfinite(s.get<double>()))
          throw InputError(what + "KHR_materials_emissive_strength.emissiveStrength must be a number >= 0");
        pbr.emissive *= s.get<float>();
      } else {
        warnings_.push_back(what + "extension " + name + " is not supported (ignored)");
      }
    }
    if (g.alphaMode == "MASK") {
      if (!(g.alphaCutoff >= 0.0) || !std::isfinite(g.alphaCutoff))
        throw InputError(what + "alphaCutoff must be a number >= 0");
      pbr.alpha_mask = true, pbr.alpha_cutoff = float(g.alphaCutoff);
    } else if (g.alphaMode == "BLEND") {
      pbr.alpha_blend = true;
    } else if (g.alphaMode != "OPAQUE") {
      throw InputError(what + "alphaMode '" + g.alphaMode + "' is not OPAQUE, MASK or BLEND");
    }
    m.double_sided = g.doubleSided;

    auto texture = [&](const auto& info, const char* field, bool srgb) -> std::shared_ptr<const TextureImage> {
      if (info.index < 0) return nullptr;
      const std::string f = what + field + ": ";
      if (std::size_t(info.index) >= model_.textures.size())
        throw InputError(f + "texture " + std::to_string(info.index) + " out of range (" +
                         std::to_string(model_.textures.size()) + ")");
      const tinygltf::Texture& t = model_.textures[std::size_t(info.index)];
      if (t.source < 0 || std::size_t(t.source) >= model_.images.size())
        throw InputError(f + "texture " + std::to_string(info.index) +
                         " has no PNG or JPEG image (source missing or out of range; images in "
                         "extensions such as KHR_texture_basisu are not supported)");
      int set = info.texCoord;
      glm::mat3 transform(1.0f);
      const json te = parse_extensions(info.extensions_json_string, f);
      if (te.contains("KHR_texture_transform")) {
        const json& tt = te["KHR_texture_transform"];
        try {
          if (!tt.is_object()) throw std::invalid_argument("not an object");
          transform = texture_transform(tt);
          if (tt.contains("texCoord")) set = tt["texCoord"].get<int>();
        } catch (const std::exception& e) {
          throw InputError(f + "KHR_texture_transform: " + e.what());
        }
      }
      if (set != 0 && set != 1)
        throw InputError(f + "texCoord " + std::to_string(set) + ": only TEXCOORD_0 and TEXCOORD_1 are read");
      if (!uv.textured) {
        uv = {true, set, transform};
      } else if (set != uv.set) {
        throw InputError(f + "uses TEXCOORD_" + std::to_string(set) + ", the material's other textures TEXCOORD_" +
                         std::to_string(uv.set) + " (one set per material is supported)");
      } else if (transform != uv.transform) {
        throw InputError(f + "its KHR_texture_transform differs from the material's other textures' "
                         "(one transform per material is supported)");
      }
      return decode ? image(std::size_t(t.source), srgb, f) : nullptr;
    };
    m.albedo = texture(p.baseColorTexture, "baseColorTexture", true);
    pbr.metallic_roughness = texture(p.metallicRoughnessTexture, "metallicRoughnessTexture", false);
    m.normal_map = texture(g.normalTexture, "normalTexture", false);
    if (!std::isfinite(g.normalTexture.scale))
      throw InputError(what + "normalTexture.scale is not a finite number");
    m.normal_strength = float(g.normalTexture.scale);
    pbr.occlusion = texture(g.occlusionTexture, "occlusionTexture", false);
    if (!in_unit(g.occlusionTexture.strength))
      throw InputError(what + "occlusionTexture.strength must be in [0, 1]");
    pbr.occlusion_strength = float(g.occlusionTexture.strength);
    pbr.emissive_map = texture(g.emissiveTexture, "emissiveTexture", true);
    return m;
  }

  // An image decoded once per colour space (sRGB for colours, linear for data).
  std::shared_ptr<const TextureImage> image(std::size_t index, bool srgb, const std::string& f) {
    auto& cached = images_[{index, srgb}];
    if (cached) return cached;
    const tinygltf::Image& im = model_.images[index];
    const std::string what = f + "image " + std::to_string(index) +
                             (im.name.empty() ? std::string() : " '" + im.name + "'");
    if (im.image.empty() || im.image.size() > std::size_t(std::numeric_limits<int>::max()))
      throw InputError(what + " has no data");
    const auto* bytes = im.image.data();
    const int size = int(im.image.size());
    int w = 0, h = 0, c = 0;
    if (!stbi_info_from_memory(bytes, size, &w, &h, &c))
      throw InputError(what + " cannot be decoded (" + stbi_failure_reason() + "; PNG and JPEG are read)");
    if (w < 1 || h < 1 || w > kMaxTextureSide || h > kMaxTextureSide)
      throw InputError(what + " is " + std::to_string(w) + " x " + std::to_string(h) +
                       " texels (1 to " + std::to_string(kMaxTextureSide) + " a side)");
    // Grey (+ alpha) as RGB(A): every field reads the channels its role names (B metal, G rough).
    const int want = c == 2 ? 4 : c == 1 ? 3 : 0;
    unsigned char* px = stbi_load_from_memory(bytes, size, &w, &h, &c, want);
    if (!px) throw InputError(what + " cannot be decoded (" + stbi_failure_reason() + ")");
    auto t = std::make_shared<TextureImage>();
    t->width = w, t->height = h, t->channels = want ? want : c, t->srgb = srgb;
    t->u8.assign(px, px + std::size_t(w) * std::size_t(h) * std::size_t(t->channels));
    stbi_image_free(px);
    cached = std::move(t);
    return cached;
  }

  // arlight's baked floor occlusion (Mesh::ground), in the loaded mesh's frame: the document's
  // extras.arlight_ground = {min: [x, z], max: [x, z], size: N, accessor: A (N x N floats)[,
  // transfer_accessor: T (N x N x 9 floats, GroundOcclusion::hidden_transfer)]}.
  void read_ground() {
    if (model_.extras_json_string.empty()) return;
    json extras;
    try {
      extras = json::parse(model_.extras_json_string);
    } catch (const json::exception& e) {
      throw InputError(where_ + "extras: " + e.what());
    }
    if (!extras.is_object() || !extras.contains("arlight_ground")) return;
    const json& g = extras["arlight_ground"];
    const std::string what = where_ + "extras.arlight_ground: ";
    const auto mn = g.at("min").get<std::vector<float>>(),
               mx = g.at("max").get<std::vector<float>>();
    const int size = g.at("size").get<int>();
    if (mn.size() != 2 || mx.size() != 2 || !(mn[0] < mx[0]) || !(mn[1] < mx[1]))
      throw InputError(what + "min and max must be [x, z] with min < max");
    if (size < 2 || size > 1024) throw InputError(what + "size must be 2 to 1024");
    std::vector<float> occluded = read_accessor(g.at("accessor").get<int>(), 1);
    if (occluded.size() != std::size_t(size) * std::size_t(size))
      throw InputError(what + "the accessor holds " + std::to_string(occluded.size()) +
                       " values, not size x size");
    for (const float v : occluded)
      if (!(v >= 0.0f && v <= 1.0f)) throw InputError(what + "an occlusion outside [0, 1]");
    std::vector<float> hidden;
    if (g.contains("transfer_accessor")) {
      hidden = read_accessor(g.at("transfer_accessor").get<int>(), 1);
      if (hidden.size() != std::size_t(size) * std::size_t(size) * kTransferCoefficients)
        throw InputError(what + "the transfer accessor holds " + std::to_string(hidden.size()) +
                         " values, not size x size x 9");
      for (const float v : hidden)
        if (!(std::abs(v) <= 2.0f))
          throw InputError(what + "a transfer coefficient not finite or beyond 2");
    }
    mesh_.ground = {{mn[0], mn[1]}, {mx[0], mx[1]}, size, std::move(occluded), std::move(hidden)};
  }

  template <typename T>
  const T& element(const std::vector<T>& list, int index, const char* kind) const {
    if (index < 0 || std::size_t(index) >= list.size())
      throw InputError(where_ + kind + " index " + std::to_string(index) + " out of range (" +
                       std::to_string(list.size()) + ")");
    return list[std::size_t(index)];
  }

  struct View {
    std::span<const std::uint8_t> bytes;
    std::size_t stride = 0;
  };

  View buffer_view(int index) const {
    const tinygltf::BufferView& v = element(model_.bufferViews, index, "bufferView");
    const std::vector<unsigned char>& buf = element(model_.buffers, v.buffer, "buffer").data;
    if (v.byteOffset > buf.size() || v.byteLength > buf.size() - v.byteOffset)
      throw InputError(where_ + "bufferView " + std::to_string(index) + " (offset " +
                       std::to_string(v.byteOffset) + ", length " + std::to_string(v.byteLength) +
                       ") is beyond its buffer of " + std::to_string(buf.size()) + " bytes");
    return {std::span<const std::uint8_t>(buf).subspan(v.byteOffset, v.byteLength), v.byteStride};
  }

  static int type_components(int type) {
    switch (type) {
      case TINYGLTF_TYPE_SCALAR: return 1;
      case TINYGLTF_TYPE_VEC2: return 2;
      case TINYGLTF_TYPE_VEC3: return 3;
      case TINYGLTF_TYPE_VEC4: return 4;
      default: return 0;
    }
  }

  // Reads an accessor as floats (normalized integers are converted), `comps` per element.
  std::vector<float> read_accessor(int index, int comps, bool allow_ints = false) const {
    const tinygltf::Accessor& a = element(model_.accessors, index, "accessor");
    const std::string name = "accessor " + std::to_string(index);
    if (a.sparse.isSparse) throw InputError(where_ + "sparse accessors are not supported");
    if (type_components(a.type) != comps)
      throw InputError(where_ + name + " has " + std::to_string(type_components(a.type)) +
                       " components a value, expected " + std::to_string(comps));
    const int ct = a.componentType;
    const std::size_t csize = ct == 5126 || ct == 5125 ? 4 : ct == 5123 || ct == 5122 ? 2
                              : ct == 5121 || ct == 5120 ? 1 : 0;
    if (csize == 0) throw InputError(where_ + name + ": bad componentType");
    if (ct != 5126 && !a.normalized && !allow_ints)
      throw InputError(where_ + name + " must be float");
    const std::size_t count = a.count;
    if (count > (std::size_t(1) << 28)) throw InputError(where_ + name + ": count beyond 2^28");
    std::vector<float> out(count * std::size_t(comps), 0.0f);
    if (a.bufferView < 0) return out;  // all zeros, as the spec says
    const View v = buffer_view(a.bufferView);
    const std::size_t offset = a.byteOffset;
    const std::size_t elem = csize * std::size_t(comps);
    const std::size_t stride = v.stride ? v.stride : elem;
    if (count > 0 && (offset > v.bytes.size() || (count - 1) * stride + elem > v.bytes.size() - offset))
      throw InputError(where_ + name + " (" + std::to_string(count) + " x " +
                       std::to_string(comps) + " values) out of range of its bufferView of " +
                       std::to_string(v.bytes.size()) + " bytes");
    for (std::size_t i = 0; i < count; ++i)
      for (int c = 0; c < comps; ++c) {
        const std::uint8_t* p = v.bytes.data() + offset + i * stride + std::size_t(c) * csize;
        float x = 0;
        switch (ct) {
          case 5126: std::memcpy(&x, p, 4); break;
          case 5125: { std::uint32_t u; std::memcpy(&u, p, 4); x = float(u); break; }
          case 5123: { std::uint16_t u; std::memcpy(&u, p, 2); x = a.normalized ? u / 65535.0f : float(u); break; }
          case 5122: { std::int16_t u; std::memcpy(&u, p, 2); x = a.normalized ? std::max(u / 32767.0f, -1.0f) : float(u); break; }
          case 5121: x = a.normalized ? *p / 255.0f : float(*p); break;
          default: x = a.normalized ? std::max(std::int8_t(*p) / 127.0f, -1.0f) : float(std::int8_t(*p)); break;
        }
        out[i * std::size_t(comps) + std::size_t(c)] = x;
      }
    return out;
  }

  std::vector<std::uint32_t> read_indices(int index) const {
    const tinygltf::Accessor& a = element(model_.accessors, index, "accessor");
    const int ct = a.componentType;
    if (ct != 5121 && ct != 5123 && ct != 5125)
      throw InputError(where_ + "index accessor " + std::to_string(index) + " must be u8/u16/u32");
    if (a.normalized) throw InputError(where_ + "index accessor is normalized");
    const std::vector<float> f = read_accessor(index, 1, true);
    // u32 indices above 2^24 would lose precision through float: read them directly.
    std::vector<std::uint32_t> out(f.size());
    if (ct == 5125 && a.bufferView >= 0) {
      const View v = buffer_view(a.bufferView);
      const std::size_t stride = v.stride ? v.stride : 4;
      for (std::size_t i = 0; i < out.size(); ++i)
        std::memcpy(&out[i], v.bytes.data() + a.byteOffset + i * stride, 4);
    } else {
      for (std::size_t i = 0; i < out.size(); ++i) out[i] = std::uint32_t(f[i]);
    }
    return out;
  }

  struct Primitive {
    std::vector<glm::vec3> positions, normals;
    std::vector<glm::vec2> uvs;
    std::vector<glm::vec4> tangents;   // TANGENT (xyz along u, w the bitangent's sign)
    std::vector<glm::vec4> occlusion;  // _OCCLUSION (arlight's baked occlusion, Mesh::occlusion)
    std::vector<float> transfer;       // _SH_TRANSFER_0..2 (Mesh::transfer: 3 VEC3s, 9 per vertex)
    std::vector<std::uint32_t> indices;
  };

#ifdef ARLIGHT_NO_DRACO
  Primitive decode_draco(const json&, const std::string&) const {
    throw InputError(where_ +
                     "KHR_draco_mesh_compression: this build has no Draco decoder "
                     "(re-encode the model with `arlight-model convert`)");
  }
#else
  Primitive decode_draco(const json& ext, const std::string& uv_name) const {
    const View v = buffer_view(ext.at("bufferView").get<int>());
    draco::DecoderBuffer buf;
    buf.Init(reinterpret_cast<const char*>(v.bytes.data()), v.bytes.size());
    draco::Decoder decoder;
    auto result = decoder.DecodeMeshFromBuffer(&buf);
    if (!result.ok())
      throw InputError(where_ + "Draco decode failure: " + result.status().error_msg_string());
    std::unique_ptr<draco::Mesh> dm = std::move(result).value();
    Primitive p;
    const json attrs = ext.value("attributes", json::object());
    auto read = [&](const std::string& name, int comps, auto& out) {
      if (!attrs.contains(name)) return;
      const draco::PointAttribute* att = dm->GetAttributeByUniqueId(attrs[name].get<std::uint32_t>());
      if (!att) throw InputError(where_ + "Draco mesh has no attribute for " + name);
      out.resize(dm->num_points());
      for (draco::PointIndex i(0); i < dm->num_points(); ++i) {
        float val[4] = {0, 0, 0, 0};
        if (!att->ConvertValue<float>(att->mapped_index(i), std::int8_t(comps), val))
          throw InputError(where_ + "Draco attribute " + name + " cannot be read as float");
        std::memcpy(&out[i.value()], val, sizeof(float) * std::size_t(comps));
      }
    };
    read("POSITION", 3, p.positions);
    read("NORMAL", 3, p.normals);
    read(uv_name, 2, p.uvs);
    p.indices.reserve(std::size_t(dm->num_faces()) * 3);
    for (draco::FaceIndex f(0); f < dm->num_faces(); ++f)
      for (int k = 0; k < 3; ++k) p.indices.push_back(dm->face(f)[k].value());
    return p;
  }
#endif  // ARLIGHT_NO_DRACO

  template <typename V>
  static std::vector<V> as_vec(const std::vector<float>& f) {
    std::vector<V> out(f.size() * sizeof(float) / sizeof(V));
    if (!out.empty()) std::memcpy(out.data(), f.data(), out.size() * sizeof(V));
    return out;
  }

  // `uv_name`: the TEXCOORD_n its material's textures read (TEXCOORD_0 without a material).
  Primitive read_primitive(const tinygltf::Primitive& prim, const std::string& uv_name,
                           std::pair<std::size_t, std::size_t> mesh_primitive) const {
    const auto& attrs = prim.attributes;
    auto attr = [&](const std::string& name) { return attrs.at(name); };
    const json ext = parse_extensions(prim.extensions_json_string, where_ + "primitive ");
    if (ext.contains("KHR_draco_mesh_compression")) {
      Primitive p = decode_draco(ext["KHR_draco_mesh_compression"], uv_name);
      // The glTF accessors describe the decoded data: their counts must agree.
      auto count = [&](int accessor) { return element(model_.accessors, accessor, "accessor").count; };
      if (attrs.count("POSITION") && count(attr("POSITION")) != p.positions.size())
        throw InputError(where_ + "Draco decoded " + std::to_string(p.positions.size()) +
                         " vertices, the POSITION accessor says " +
                         std::to_string(count(attr("POSITION"))));
      const auto moved = draco_indices_.find(mesh_primitive);
      const std::size_t indices = moved != draco_indices_.end() ? moved->second
                                  : prim.indices >= 0        ? count(prim.indices)
                                                             : p.indices.size();
      if (indices != p.indices.size())
        throw InputError(where_ + "Draco decoded " + std::to_string(p.indices.size()) +
                         " indices, the indices accessor says " + std::to_string(indices));
      return p;
    }
    Primitive p;
    if (!attrs.count("POSITION")) throw InputError(where_ + "primitive without POSITION");
    p.positions = as_vec<glm::vec3>(read_accessor(attr("POSITION"), 3));
    if (attrs.count("NORMAL")) p.normals = as_vec<glm::vec3>(read_accessor(attr("NORMAL"), 3));
    if (attrs.count(uv_name)) p.uvs = as_vec<glm::vec2>(read_accessor(attr(uv_name), 2));
    if (attrs.count("TANGENT")) {
      p.tangents = as_vec<glm::vec4>(read_accessor(attr("TANGENT"), 4));
      for (const glm::vec4& t : p.tangents)
        if (!std::isfinite(t.x + t.y + t.z) || !(std::abs(t.w) == 1.0f))
          throw InputError(where_ + "TANGENT: a tangent not finite or its w not +-1");
    }
    if (attrs.count("_OCCLUSION")) {
      p.occlusion = as_vec<glm::vec4>(read_accessor(attr("_OCCLUSION"), 4));
      for (const glm::vec4& o : p.occlusion)
        if (!(o.w >= 0.0f && o.w <= 1.0f) || !std::isfinite(o.x + o.y + o.z))
          throw InputError(where_ +
                           "_OCCLUSION: an occlusion outside [0, 1] or a bent normal not finite");
    }
    if (attrs.count("_SH_TRANSFER_0")) {
      // Three VEC3 accessors of coefficients 0-2, 3-5 and 6-8; |t_k| <= max |Y_k| < 1.1.
      std::vector<std::vector<float>> parts;
      for (const char* name : {"_SH_TRANSFER_0", "_SH_TRANSFER_1", "_SH_TRANSFER_2"}) {
        if (!attrs.count(name))
          throw InputError(where_ + name + " missing beside _SH_TRANSFER_0");
        parts.push_back(read_accessor(attr(name), 3));
        if (parts.back().size() != parts.front().size())
          throw InputError(where_ + "the _SH_TRANSFER_ accessors have different counts");
        for (const float v : parts.back())
          if (!(std::abs(v) <= 2.0f))
            throw InputError(where_ + name + ": a coefficient not finite or beyond 2");
      }
      const std::size_t n = parts[0].size() / 3;
      p.transfer.resize(n * kTransferCoefficients);
      for (std::size_t i = 0; i < n; ++i)
        for (std::size_t k = 0; k < 3; ++k)
          for (std::size_t c = 0; c < 3; ++c)
            p.transfer[i * kTransferCoefficients + 3 * k + c] = parts[k][3 * i + c];
    }
    if (prim.indices >= 0) {
      p.indices = read_indices(prim.indices);
    } else {
      p.indices.resize(p.positions.size() - p.positions.size() % 3);
      for (std::size_t i = 0; i < p.indices.size(); ++i) p.indices[i] = std::uint32_t(i);
    }
    return p;
  }

  void add_mesh(int mesh_index, const glm::dmat4& world) {
    const tinygltf::Mesh& m = element(model_.meshes, mesh_index, "mesh");
    const glm::mat4 M(world);
    const glm::mat3 N = glm::inverseTranspose(glm::mat3(M));
    const bool flip = glm::determinant(glm::mat3(M)) < 0.0f;
    for (std::size_t prim_index = 0; prim_index < m.primitives.size(); ++prim_index) {
      const tinygltf::Primitive& prim = m.primitives[prim_index];
      if (prim.mode != -1 && prim.mode != TINYGLTF_MODE_TRIANGLES) continue;  // points, lines
      if (prim.material >= 0 && std::size_t(prim.material) >= material_uv_.size())
        throw InputError(where_ + "mesh " + std::to_string(mesh_index) + ": material " +
                         std::to_string(prim.material) + " out of range (" +
                         std::to_string(material_uv_.size()) + ")");
      const MaterialUv uv = prim.material >= 0 ? material_uv_[std::size_t(prim.material)] : MaterialUv{};
      const std::string uv_name = "TEXCOORD_" + std::to_string(uv.set);
      // Primitives that share their vertices (the same accessors, uv set and transform, under
      // the same node: a mesh split by material) share them here too; only indices are read.
      const std::string key = vertex_key(prim, uv, world);
      if (const auto shared = shared_vertices_.find(key); shared != shared_vertices_.end()) {
        const auto [base, n] = shared->second;
        std::vector<std::uint32_t> indices;
        if (prim.indices >= 0) {
          indices = read_indices(prim.indices);
        } else {
          indices.resize(n - n % 3);
          for (std::size_t i = 0; i < indices.size(); ++i) indices[i] = std::uint32_t(i);
        }
        add_triangles(indices, n, base, flip, prim.material);
        continue;
      }
      Primitive p = read_primitive(prim, uv_name, {std::size_t(mesh_index), prim_index});
      if (uv.textured && p.uvs.empty())
        throw InputError(material_where(std::size_t(prim.material)) + "has textures, but a primitive of mesh " +
                         std::to_string(mesh_index) + " that uses it has no " + uv_name);
      for (glm::vec2& t : p.uvs) t = glm::vec2(uv.transform * glm::vec3(t, 1.0f));
      const std::size_t n = p.positions.size();
      if (n == 0) throw InputError(where_ + "primitive without positions");
      if ((!p.normals.empty() && p.normals.size() != n) || (!p.uvs.empty() && p.uvs.size() != n) ||
          (!p.occlusion.empty() && p.occlusion.size() != n) ||
          (!p.transfer.empty() && p.transfer.size() != n * kTransferCoefficients))
        throw InputError(where_ + "primitive attributes have different counts");
      for (std::uint32_t i : p.indices)  // (before anything is appended)
        if (i >= n)
          throw InputError(where_ + "index " + std::to_string(i) + " out of range (" +
                           std::to_string(n) + " vertices)");
      if (!key.empty()) shared_vertices_[key] = {std::uint32_t(mesh_.positions.size()), n};
      // uvs for all or none: a primitive without uvs in a mixed file gets (0, 0).
      if (!p.uvs.empty() && !has_uvs_ && !mesh_.positions.empty())
        mesh_.uvs.assign(mesh_.positions.size(), glm::vec2(0.0f));
      if (!p.uvs.empty()) has_uvs_ = true;
      if (has_uvs_ && p.uvs.empty()) p.uvs.assign(n, glm::vec2(0.0f));
      // Occlusion likewise; a primitive without it counts as open (nothing baked).
      const glm::vec4 open(0.0f, 0.0f, 0.0f, 1.0f);
      if (!p.occlusion.empty() && !has_occlusion_ && !mesh_.positions.empty())
        mesh_.occlusion.assign(mesh_.positions.size(), open);
      if (!p.occlusion.empty()) has_occlusion_ = true;
      if (has_occlusion_ && p.occlusion.empty()) p.occlusion.assign(n, open);
      // The transfer likewise; open: the clamped cosine's, which needs the normal (below).
      if (!p.transfer.empty() && !has_transfer_ && !mesh_.positions.empty())
        mesh_.transfer = open_transfers(mesh_.normals);
      if (!p.transfer.empty()) has_transfer_ = true;
      Mesh part;
      part.positions = std::move(p.positions);
      part.indices = std::move(p.indices);
      if (p.normals.empty()) compute_normals(part); else part.normals = std::move(p.normals);
      const auto base = std::uint32_t(mesh_.positions.size());
      for (std::size_t i = 0; i < n; ++i) {
        mesh_.positions.push_back(glm::vec3(M * glm::vec4(part.positions[i], 1.0f)));
        const glm::vec3 nn = N * part.normals[i];
        const float l = glm::length(nn);
        mesh_.normals.push_back(l > 0.0f ? nn / l : glm::vec3(0, 1, 0));
        if (has_occlusion_) {  // the bent normal turns with the normals
          const glm::vec3 b = N * glm::vec3(p.occlusion[i]);
          const float lb = glm::length(b);
          mesh_.occlusion.push_back(
              glm::vec4(lb > 0.0f ? b / lb : glm::vec3(0.0f), p.occlusion[i].w));
        }
      }
      if (has_uvs_) mesh_.uvs.insert(mesh_.uvs.end(), p.uvs.begin(), p.uvs.end());
      file_tangents_ = file_tangents_ && p.tangents.size() == n && uv.transform == glm::mat3(1.0f);
      if (file_tangents_)
        for (const glm::vec4& t : p.tangents) {  // turned with the node; a mirror flips w
          const glm::vec3 tt = glm::mat3(M) * glm::vec3(t);
          const float l = glm::length(tt);
          mesh_.tangents.push_back(glm::vec4(l > 0.0f ? tt / l : glm::vec3(1, 0, 0), flip ? -t.w : t.w));
        }
      if (has_transfer_) {
        const std::size_t first = mesh_.transfer.size();
        if (p.transfer.empty()) {
          const std::vector<float> open =
              open_transfers(std::span(mesh_.normals).subspan(mesh_.normals.size() - n, n));
          mesh_.transfer.insert(mesh_.transfer.end(), open.begin(), open.end());
        } else {
          mesh_.transfer.insert(mesh_.transfer.end(), p.transfer.begin(), p.transfer.end());
          rotate_transfer(std::span(mesh_.transfer).subspan(first), glm::dmat3(N));
        }
      }
      add_triangles(part.indices, n, base, flip, prim.material);
    }
  }

  // A primitive's triangles (indices into its n vertices at `base`) as a part of the mesh;
  // `flip` (a mirroring node) turns their winding back to counter-clockwise.
  void add_triangles(const std::vector<std::uint32_t>& indices, std::size_t n, std::uint32_t base,
                     bool flip, int material) {
    if (indices.size() % 3 != 0) throw InputError(where_ + "index count is not a multiple of 3");
    for (const std::uint32_t i : indices)
      if (i >= n)
        throw InputError(where_ + "index " + std::to_string(i) + " out of range (" +
                         std::to_string(n) + " vertices)");
    mesh_.parts.push_back({std::uint32_t(mesh_.indices.size()), std::uint32_t(indices.size()), material});
    for (std::size_t i = 0; i < indices.size(); i += 3) {
      mesh_.indices.push_back(base + indices[i]);
      mesh_.indices.push_back(base + indices[i + (flip ? 2 : 1)]);
      mesh_.indices.push_back(base + indices[i + (flip ? 1 : 2)]);
    }
  }

  // What makes two primitives' vertices the same: their attribute accessors, the uvs their
  // materials read, the node's transform. Empty for Draco primitives (each its own stream).
  static std::string vertex_key(const tinygltf::Primitive& prim, const MaterialUv& uv,
                                const glm::dmat4& world) {
    if (prim.extensions_json_string.find("KHR_draco_mesh_compression") != std::string::npos)
      return {};
    std::string key;
    for (const auto& [name, accessor] : prim.attributes)
      key.append(name).append("=").append(std::to_string(accessor)).append(";");
    key.append("uv").append(std::to_string(uv.set));
    for (int c = 0; c < 3; ++c)
      for (int r = 0; r < 3; ++r) key.append(",").append(std::to_string(uv.transform[c][r]));
    for (int c = 0; c < 4; ++c)
      for (int r = 0; r < 4; ++r) key.append(",").append(std::to_string(world[c][r]));
    return key;
  }

  glm::dmat4 local_transform(const tinygltf::Node& node) const {
    if (!node.matrix.empty()) {
      if (node.matrix.size() != 16) throw InputError(where_ + "node matrix must have 16 numbers");
      return glm::make_mat4(node.matrix.data());  // column-major, as glTF stores it
    }
    glm::dmat4 t(1.0);
    if (!node.translation.empty()) {
      const auto& v = node.translation;
      if (v.size() != 3) throw InputError(where_ + "node translation must have 3 numbers");
      t[3] = glm::dvec4(v[0], v[1], v[2], 1.0);
    }
    glm::dmat4 r(1.0);
    if (!node.rotation.empty()) {
      const auto& q = node.rotation;  // x, y, z, w
      if (q.size() != 4) throw InputError(where_ + "node rotation must have 4 numbers");
      r = glm::mat4_cast(glm::normalize(glm::dquat(q[3], q[0], q[1], q[2])));
    }
    glm::dmat4 s(1.0);
    if (!node.scale.empty()) {
      const auto& v = node.scale;
      if (v.size() != 3) throw InputError(where_ + "node scale must have 3 numbers");
      s[0][0] = v[0], s[1][1] = v[1], s[2][2] = v[2];
    }
    return t * r * s;
  }

  void visit(int index, const glm::dmat4& parent, int depth) {
    if (depth > 64) throw InputError(where_ + "node hierarchy deeper than 64 (a cycle?)");
    const tinygltf::Node& node = element(model_.nodes, index, "node");
    const glm::dmat4 world = parent * local_transform(node);
    if (node.mesh >= 0) add_mesh(node.mesh, world);
    for (const int c : node.children) visit(c, world, depth + 1);
  }

  std::string where_;
  FileAccess files_;
  DracoIndexCounts draco_indices_;
  // vertex_key -> the first vertex and count of vertices already read
  std::map<std::string, std::pair<std::uint32_t, std::size_t>> shared_vertices_;
  tinygltf::Model model_;
  std::vector<MaterialUv> material_uv_;  // one per glTF material
  std::vector<Material> materials_;
  std::vector<std::string> material_names_, warnings_;
  std::map<std::pair<std::size_t, bool>, std::shared_ptr<const TextureImage>> images_;
  Mesh mesh_;
  bool has_uvs_ = false, has_occlusion_ = false, has_transfer_ = false;
  bool file_tangents_ = true;  // every primitive so far gave TANGENT (mesh_.tangents holds them)
};

GltfModel load(const std::vector<std::uint8_t>& bytes, const std::filesystem::path& name,
               bool on_disk, bool with_materials) {
  try {
    return GltfReader(bytes, name, on_disk).load(with_materials);
  } catch (const json::exception& e) {
    // Wrong types or missing keys in arlight's extras and the extensions it reads.
    throw InputError(where_prefix(name) + "malformed glTF: " + e.what());
  }
}

}  // namespace

GltfModel load_gltf_model(const std::filesystem::path& path) {
  return load(read_file(path, where_prefix(path)), path, true, true);
}

GltfModel load_gltf_model(std::span<const std::uint8_t> bytes, const std::string& name) {
  return load(std::vector<std::uint8_t>(bytes.begin(), bytes.end()), name, false, true);
}

Mesh load_gltf(const std::filesystem::path& path) {
  return load(read_file(path, where_prefix(path)), path, true, false).mesh;
}

Mesh load_gltf(std::span<const std::uint8_t> bytes, const std::string& name) {
  return load(std::vector<std::uint8_t>(bytes.begin(), bytes.end()), name, false, false).mesh;
}

}  // namespace arlight::render
