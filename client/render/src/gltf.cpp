// glTF 2.0 reading (.glb and .gltf): the document through tinygltf (gltf_document.cpp), the
// materials (gltf_materials.cpp), and here the geometry: every accessor bounds-checked (tinygltf
// leaves that to its caller), KHR_draco_mesh_compression decoded with libdraco, the node
// hierarchy, the parts and their materials' uvs. Problems throw InputError("'<file>': <what>"). ARLIGHT_NO_DRACO (the browser client's WebAssembly build: no libdraco
// there) leaves Draco out: such models are refused by name, and `arlight-model convert`
// re-encodes them without it.
#ifndef ARLIGHT_NO_DRACO
#include <draco/compression/decode.h>
#endif
#include <cmath>
#include <cstring>
#include <glm/gtc/matrix_inverse.hpp>
#include <glm/gtc/quaternion.hpp>
#include <glm/gtc/type_ptr.hpp>
#include <map>
#include <nlohmann/json.hpp>
#include <span>
#include <string>

#include "arlight/common/error.hpp"
#include "arlight/common/sh.hpp"
#include "arlight/render/gltf.hpp"
#include "gltf_document.hpp"
#include "gltf_materials.hpp"

namespace arlight::render {

namespace {

using namespace gltf_detail;

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

class GltfReader {
 public:
  // `name` appears in messages; with `on_disk`, buffers and images may be files beside it.
  GltfReader(const std::vector<std::uint8_t>& bytes, const std::filesystem::path& name,
             bool on_disk) {
    read_document(bytes, name, on_disk, doc_);
  }

  GltfModel load(bool with_materials) {
    GltfMaterials materials = read_materials(doc_, with_materials);
    material_uv_ = std::move(materials.uv);
    std::vector<int> roots;
    if (!doc_.model.scenes.empty()) {
      const int scene = std::max(doc_.model.defaultScene, 0);
      if (std::size_t(scene) >= doc_.model.scenes.size())
        throw InputError(doc_.where + "scene index out of range");
      roots = doc_.model.scenes[std::size_t(scene)].nodes;
    } else {
      std::vector<bool> child(doc_.model.nodes.size(), false);
      for (const tinygltf::Node& n : doc_.model.nodes)
        for (const int c : n.children)
          if (c >= 0 && std::size_t(c) < child.size()) child[std::size_t(c)] = true;
      for (std::size_t i = 0; i < child.size(); ++i)
        if (!child[i]) roots.push_back(int(i));
    }
    for (int r : roots) visit(r, glm::dmat4(1.0), 0);
    if (mesh_.positions.empty()) throw InputError(doc_.where + "no triangle meshes in the scene");
    compute_bounds(mesh_);
    // The file's tangents when every primitive gave them for the uvs as they are (no
    // KHR_texture_transform applied); else MikkTSpace-style ones from the uvs.
    if (has_uvs_ && !(file_tangents_ && mesh_.tangents.size() == mesh_.positions.size()))
      compute_tangents(mesh_);
    read_ground();
    GltfModel out;
    out.mesh = std::move(mesh_);
    if (with_materials) {
      out.materials = std::move(materials.materials);
      out.material_names = std::move(materials.names);
      out.warnings = std::move(materials.warnings);
    }
    return out;
  }

 private:
  // arlight's baked floor occlusion (Mesh::ground), in the loaded mesh's frame: the document's
  // extras.arlight_ground = {min: [x, z], max: [x, z], size: N, accessor: A (N x N floats)[,
  // transfer_accessor: T (N x N x 9 floats, GroundOcclusion::hidden_transfer)]}.
  void read_ground() {
    if (doc_.model.extras_json_string.empty()) return;
    json extras;
    try {
      extras = json::parse(doc_.model.extras_json_string);
    } catch (const json::exception& e) {
      throw InputError(doc_.where + "extras: " + e.what());
    }
    if (!extras.is_object() || !extras.contains("arlight_ground")) return;
    const json& g = extras["arlight_ground"];
    const std::string what = doc_.where + "extras.arlight_ground: ";
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
      throw InputError(doc_.where + kind + " index " + std::to_string(index) + " out of range (" +
                       std::to_string(list.size()) + ")");
    return list[std::size_t(index)];
  }

  struct View {
    std::span<const std::uint8_t> bytes;
    std::size_t stride = 0;
  };

  View buffer_view(int index) const {
    const tinygltf::BufferView& v = element(doc_.model.bufferViews, index, "bufferView");
    const std::vector<unsigned char>& buf = element(doc_.model.buffers, v.buffer, "buffer").data;
    if (v.byteOffset > buf.size() || v.byteLength > buf.size() - v.byteOffset)
      throw InputError(doc_.where + "bufferView " + std::to_string(index) + " (offset " +
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
    const tinygltf::Accessor& a = element(doc_.model.accessors, index, "accessor");
    const std::string name = "accessor " + std::to_string(index);
    if (a.sparse.isSparse) throw InputError(doc_.where + "sparse accessors are not supported");
    if (type_components(a.type) != comps)
      throw InputError(doc_.where + name + " has " + std::to_string(type_components(a.type)) +
                       " components a value, expected " + std::to_string(comps));
    const int ct = a.componentType;
    const std::size_t csize = ct == 5126 || ct == 5125 ? 4 : ct == 5123 || ct == 5122 ? 2
                              : ct == 5121 || ct == 5120 ? 1 : 0;
    if (csize == 0) throw InputError(doc_.where + name + ": bad componentType");
    if (ct != 5126 && !a.normalized && !allow_ints)
      throw InputError(doc_.where + name + " must be float");
    const std::size_t count = a.count;
    if (count > (std::size_t(1) << 28)) throw InputError(doc_.where + name + ": count beyond 2^28");
    std::vector<float> out(count * std::size_t(comps), 0.0f);
    if (a.bufferView < 0) return out;  // all zeros, as the spec says
    const View v = buffer_view(a.bufferView);
    const std::size_t offset = a.byteOffset;
    const std::size_t elem = csize * std::size_t(comps);
    const std::size_t stride = v.stride ? v.stride : elem;
    if (count > 0 && (offset > v.bytes.size() || (count - 1) * stride + elem > v.bytes.size() - offset))
      throw InputError(doc_.where + name + " (" + std::to_string(count) + " x " +
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
    const tinygltf::Accessor& a = element(doc_.model.accessors, index, "accessor");
    const int ct = a.componentType;
    if (ct != 5121 && ct != 5123 && ct != 5125)
      throw InputError(doc_.where + "index accessor " + std::to_string(index) + " must be u8/u16/u32");
    if (a.normalized) throw InputError(doc_.where + "index accessor is normalized");
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
    throw InputError(doc_.where +
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
      throw InputError(doc_.where + "Draco decode failure: " + result.status().error_msg_string());
    std::unique_ptr<draco::Mesh> dm = std::move(result).value();
    Primitive p;
    const json attrs = ext.value("attributes", json::object());
    auto read = [&](const std::string& name, int comps, auto& out) {
      if (!attrs.contains(name)) return;
      const draco::PointAttribute* att = dm->GetAttributeByUniqueId(attrs[name].get<std::uint32_t>());
      if (!att) throw InputError(doc_.where + "Draco mesh has no attribute for " + name);
      out.resize(dm->num_points());
      for (draco::PointIndex i(0); i < dm->num_points(); ++i) {
        float val[4] = {0, 0, 0, 0};
        if (!att->ConvertValue<float>(att->mapped_index(i), std::int8_t(comps), val))
          throw InputError(doc_.where + "Draco attribute " + name + " cannot be read as float");
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
    const json ext = parse_extensions(prim.extensions_json_string, doc_.where + "primitive ");
    if (ext.contains("KHR_draco_mesh_compression")) {
      Primitive p = decode_draco(ext["KHR_draco_mesh_compression"], uv_name);
      // The glTF accessors describe the decoded data: their counts must agree.
      auto count = [&](int accessor) { return element(doc_.model.accessors, accessor, "accessor").count; };
      if (attrs.count("POSITION") && count(attr("POSITION")) != p.positions.size())
        throw InputError(doc_.where + "Draco decoded " + std::to_string(p.positions.size()) +
                         " vertices, the POSITION accessor says " +
                         std::to_string(count(attr("POSITION"))));
      const auto moved = doc_.draco_indices.find(mesh_primitive);
      const std::size_t indices = moved != doc_.draco_indices.end() ? moved->second
                                  : prim.indices >= 0        ? count(prim.indices)
                                                             : p.indices.size();
      if (indices != p.indices.size())
        throw InputError(doc_.where + "Draco decoded " + std::to_string(p.indices.size()) +
                         " indices, the indices accessor says " + std::to_string(indices));
      return p;
    }
    Primitive p;
    if (!attrs.count("POSITION")) throw InputError(doc_.where + "primitive without POSITION");
    p.positions = as_vec<glm::vec3>(read_accessor(attr("POSITION"), 3));
    if (attrs.count("NORMAL")) p.normals = as_vec<glm::vec3>(read_accessor(attr("NORMAL"), 3));
    if (attrs.count(uv_name)) p.uvs = as_vec<glm::vec2>(read_accessor(attr(uv_name), 2));
    if (attrs.count("TANGENT")) {
      p.tangents = as_vec<glm::vec4>(read_accessor(attr("TANGENT"), 4));
      for (const glm::vec4& t : p.tangents)
        if (!std::isfinite(t.x + t.y + t.z) || !(std::abs(t.w) == 1.0f))
          throw InputError(doc_.where + "TANGENT: a tangent not finite or its w not +-1");
    }
    if (attrs.count("_OCCLUSION")) {
      p.occlusion = as_vec<glm::vec4>(read_accessor(attr("_OCCLUSION"), 4));
      for (const glm::vec4& o : p.occlusion)
        if (!(o.w >= 0.0f && o.w <= 1.0f) || !std::isfinite(o.x + o.y + o.z))
          throw InputError(doc_.where +
                           "_OCCLUSION: an occlusion outside [0, 1] or a bent normal not finite");
    }
    if (attrs.count("_SH_TRANSFER_0")) {
      // Three VEC3 accessors of coefficients 0-2, 3-5 and 6-8; |t_k| <= max |Y_k| < 1.1.
      std::vector<std::vector<float>> parts;
      for (const char* name : {"_SH_TRANSFER_0", "_SH_TRANSFER_1", "_SH_TRANSFER_2"}) {
        if (!attrs.count(name))
          throw InputError(doc_.where + name + " missing beside _SH_TRANSFER_0");
        parts.push_back(read_accessor(attr(name), 3));
        if (parts.back().size() != parts.front().size())
          throw InputError(doc_.where + "the _SH_TRANSFER_ accessors have different counts");
        for (const float v : parts.back())
          if (!(std::abs(v) <= 2.0f))
            throw InputError(doc_.where + name + ": a coefficient not finite or beyond 2");
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
    const tinygltf::Mesh& m = element(doc_.model.meshes, mesh_index, "mesh");
    const glm::mat4 M(world);
    const glm::mat3 N = glm::inverseTranspose(glm::mat3(M));
    const bool flip = glm::determinant(glm::mat3(M)) < 0.0f;
    for (std::size_t prim_index = 0; prim_index < m.primitives.size(); ++prim_index) {
      const tinygltf::Primitive& prim = m.primitives[prim_index];
      if (prim.mode != -1 && prim.mode != TINYGLTF_MODE_TRIANGLES) continue;  // points, lines
      if (prim.material >= 0 && std::size_t(prim.material) >= material_uv_.size())
        throw InputError(doc_.where + "mesh " + std::to_string(mesh_index) + ": material " +
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
        throw InputError(material_where(doc_, std::size_t(prim.material)) + "has textures, but a primitive of mesh " +
                         std::to_string(mesh_index) + " that uses it has no " + uv_name);
      for (glm::vec2& t : p.uvs) t = glm::vec2(uv.transform * glm::vec3(t, 1.0f));
      const std::size_t n = p.positions.size();
      if (n == 0) throw InputError(doc_.where + "primitive without positions");
      if ((!p.normals.empty() && p.normals.size() != n) || (!p.uvs.empty() && p.uvs.size() != n) ||
          (!p.occlusion.empty() && p.occlusion.size() != n) ||
          (!p.transfer.empty() && p.transfer.size() != n * kTransferCoefficients))
        throw InputError(doc_.where + "primitive attributes have different counts");
      for (std::uint32_t i : p.indices)  // (before anything is appended)
        if (i >= n)
          throw InputError(doc_.where + "index " + std::to_string(i) + " out of range (" +
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
    if (indices.size() % 3 != 0) throw InputError(doc_.where + "index count is not a multiple of 3");
    for (const std::uint32_t i : indices)
      if (i >= n)
        throw InputError(doc_.where + "index " + std::to_string(i) + " out of range (" +
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
      if (node.matrix.size() != 16) throw InputError(doc_.where + "node matrix must have 16 numbers");
      return glm::make_mat4(node.matrix.data());  // column-major, as glTF stores it
    }
    glm::dmat4 t(1.0);
    if (!node.translation.empty()) {
      const auto& v = node.translation;
      if (v.size() != 3) throw InputError(doc_.where + "node translation must have 3 numbers");
      t[3] = glm::dvec4(v[0], v[1], v[2], 1.0);
    }
    glm::dmat4 r(1.0);
    if (!node.rotation.empty()) {
      const auto& q = node.rotation;  // x, y, z, w
      if (q.size() != 4) throw InputError(doc_.where + "node rotation must have 4 numbers");
      r = glm::mat4_cast(glm::normalize(glm::dquat(q[3], q[0], q[1], q[2])));
    }
    glm::dmat4 s(1.0);
    if (!node.scale.empty()) {
      const auto& v = node.scale;
      if (v.size() != 3) throw InputError(doc_.where + "node scale must have 3 numbers");
      s[0][0] = v[0], s[1][1] = v[1], s[2][2] = v[2];
    }
    return t * r * s;
  }

  void visit(int index, const glm::dmat4& parent, int depth) {
    if (depth > 64) throw InputError(doc_.where + "node hierarchy deeper than 64 (a cycle?)");
    const tinygltf::Node& node = element(doc_.model.nodes, index, "node");
    const glm::dmat4 world = parent * local_transform(node);
    if (node.mesh >= 0) add_mesh(node.mesh, world);
    for (const int c : node.children) visit(c, world, depth + 1);
  }

  GltfDocument doc_;
  // vertex_key -> the first vertex and count of vertices already read
  std::map<std::string, std::pair<std::uint32_t, std::size_t>> shared_vertices_;
  std::vector<MaterialUv> material_uv_;  // one per glTF material
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
