// glTF 2.0 loading (.glb and .gltf), with KHR_draco_mesh_compression decoded by libdraco, and
// writing (.glb). Every read is bounds-checked; problems throw InputError("'<file>': <what>").
// ARLIGHT_NO_DRACO (the browser client's WebAssembly build: no libdraco there) leaves Draco out:
// such models are refused by name, and `arlight-model convert` re-encodes them without it.
#ifndef ARLIGHT_NO_DRACO
#include <draco/compression/decode.h>
#endif

#include <cmath>
#include <cstring>
#include <fstream>
#include <glm/gtc/matrix_inverse.hpp>
#include <glm/gtc/quaternion.hpp>
#include <glm/gtc/type_ptr.hpp>
#include <nlohmann/json.hpp>
#include <span>
#include <string>

#include "arlight/common/error.hpp"
#include "arlight/common/sh.hpp"
#include "arlight/render/mesh.hpp"

namespace arlight::render {

namespace {

using json = nlohmann::json;

constexpr std::uint32_t kGlbMagic = 0x46546C67;  // "glTF"
constexpr std::uint32_t kChunkJson = 0x4E4F534A;
constexpr std::uint32_t kChunkBin = 0x004E4942;

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

std::vector<std::uint8_t> base64_decode(std::string_view s, const std::string& where) {
  auto value = [](char c) -> int {
    if (c >= 'A' && c <= 'Z') return c - 'A';
    if (c >= 'a' && c <= 'z') return c - 'a' + 26;
    if (c >= '0' && c <= '9') return c - '0' + 52;
    if (c == '+') return 62;
    if (c == '/') return 63;
    return -1;
  };
  std::vector<std::uint8_t> out;
  unsigned acc = 0;
  int bits = 0;
  for (char c : s) {
    if (c == '=') break;
    const int v = value(c);
    if (v < 0) throw InputError(where + "invalid base64 in a data: buffer URI");
    acc = (acc << 6) | unsigned(v), bits += 6;
    if (bits >= 8) bits -= 8, out.push_back(std::uint8_t((acc >> bits) & 0xFF));
  }
  return out;
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

class GltfReader {
 public:
  explicit GltfReader(const std::filesystem::path& path)
      : GltfReader(read_file(path, where_prefix(path)), path, true) {}
  // From memory: `name` appears in messages; buffers must be in the GLB or data: URIs.
  GltfReader(std::vector<std::uint8_t> bytes, const std::filesystem::path& name, bool on_disk)
      : path_(name), where_(where_prefix(name)), file_(std::move(bytes)), on_disk_(on_disk) {
    if (file_.size() >= 4 && u32(file_.data()) == kGlbMagic)
      parse_glb();
    else if (name.extension() == ".glb")
      throw InputError(where_ + "bad magic: not a binary glTF (.glb) file");
    else
      parse_json(std::string_view(reinterpret_cast<const char*>(file_.data()), file_.size()));
  }

  Mesh load() {
    const json& nodes = get_array(doc_, "nodes");
    std::vector<int> roots;
    if (doc_.contains("scenes") && !doc_["scenes"].empty()) {
      const std::size_t scene = doc_.value("scene", 0);
      const json& scenes = get_array(doc_, "scenes");
      if (scene >= scenes.size()) throw InputError(where_ + "scene index out of range");
      for (const json& n : scenes[scene].value("nodes", json::array())) roots.push_back(n.get<int>());
    } else {
      std::vector<bool> child(nodes.size(), false);
      for (const json& n : nodes)
        for (const json& c : n.value("children", json::array()))
          if (c.get<std::size_t>() < nodes.size()) child[c.get<std::size_t>()] = true;
      for (std::size_t i = 0; i < nodes.size(); ++i)
        if (!child[i]) roots.push_back(int(i));
    }
    for (int r : roots) visit(r, glm::dmat4(1.0), 0);
    if (mesh_.positions.empty()) throw InputError(where_ + "no triangle meshes in the scene");
    compute_bounds(mesh_);
    if (has_uvs_) compute_tangents(mesh_);
    read_ground();
    return std::move(mesh_);
  }

 private:
  // arlight's baked floor occlusion (Mesh::ground), in the loaded mesh's frame: the document's
  // extras.arlight_ground = {min: [x, z], max: [x, z], size: N, accessor: A (N x N floats)[,
  // transfer_accessor: T (N x N x 9 floats, GroundOcclusion::hidden_transfer)]}.
  void read_ground() {
    if (!doc_.contains("extras") || !doc_["extras"].is_object() ||
        !doc_["extras"].contains("arlight_ground"))
      return;
    const json& g = doc_["extras"]["arlight_ground"];
    const std::string what = where_ + "extras.arlight_ground: ";
    const auto mn = g.at("min").get<std::vector<float>>(),
               mx = g.at("max").get<std::vector<float>>();
    const int size = g.at("size").get<int>();
    if (mn.size() != 2 || mx.size() != 2 || !(mn[0] < mx[0]) || !(mn[1] < mx[1]))
      throw InputError(what + "min and max must be [x, z] with min < max");
    if (size < 2 || size > 1024) throw InputError(what + "size must be 2 to 1024");
    std::vector<float> occluded = read_accessor(g.at("accessor").get<std::size_t>(), 1);
    if (occluded.size() != std::size_t(size) * std::size_t(size))
      throw InputError(what + "the accessor holds " + std::to_string(occluded.size()) +
                       " values, not size x size");
    for (const float v : occluded)
      if (!(v >= 0.0f && v <= 1.0f)) throw InputError(what + "an occlusion outside [0, 1]");
    std::vector<float> hidden;
    if (g.contains("transfer_accessor")) {
      hidden = read_accessor(g.at("transfer_accessor").get<std::size_t>(), 1);
      if (hidden.size() != std::size_t(size) * std::size_t(size) * kTransferCoefficients)
        throw InputError(what + "the transfer accessor holds " + std::to_string(hidden.size()) +
                         " values, not size x size x 9");
      for (const float v : hidden)
        if (!(std::abs(v) <= 2.0f))
          throw InputError(what + "a transfer coefficient not finite or beyond 2");
    }
    mesh_.ground = {{mn[0], mn[1]}, {mx[0], mx[1]}, size, std::move(occluded), std::move(hidden)};
  }

  void parse_glb() {
    if (file_.size() < 12) throw InputError(where_ + "truncated GLB header");
    const std::uint32_t version = u32(file_.data() + 4), length = u32(file_.data() + 8);
    if (version != 2) throw InputError(where_ + "GLB version " + std::to_string(version) + ", need 2");
    if (length > file_.size())
      throw InputError(where_ + "GLB header says " + std::to_string(length) +
                       " bytes but the file has " + std::to_string(file_.size()));
    std::size_t pos = 12;
    bool have_json = false;
    while (pos + 8 <= length) {
      const std::uint32_t chunk_len = u32(file_.data() + pos), type = u32(file_.data() + pos + 4);
      if (std::uint64_t(pos) + 8 + chunk_len > length)
        throw InputError(where_ + "chunk at byte " + std::to_string(pos) + " (length " +
                         std::to_string(chunk_len) + ") extends beyond the file");
      const std::uint8_t* data = file_.data() + pos + 8;
      if (type == kChunkJson && !have_json) {
        parse_json(std::string_view(reinterpret_cast<const char*>(data), chunk_len));
        have_json = true;
      } else if (type == kChunkBin && !have_bin_) {
        bin_ = std::span<const std::uint8_t>(data, chunk_len);
        have_bin_ = true;
      }
      pos += 8 + std::size_t(chunk_len);
    }
    if (!have_json) throw InputError(where_ + "GLB has no JSON chunk");
  }

  void parse_json(std::string_view text) {
    try {
      doc_ = json::parse(text);
    } catch (const json::exception& e) {
      throw InputError(where_ + "invalid glTF JSON: " + e.what());
    }
    if (!doc_.is_object()) throw InputError(where_ + "glTF JSON is not an object");
    const json asset = doc_.value("asset", json::object());
    if (!asset.is_object() || asset.value("version", std::string()).rfind("2.", 0) != 0)
      throw InputError(where_ + "not glTF 2.0 (asset.version)");
    for (const json& e : doc_.value("extensionsRequired", json::array()))
      if (e != "KHR_draco_mesh_compression")
        throw InputError(where_ + "unsupported required extension " + e.dump());
  }

  const json& get_array(const json& j, const char* key) const {
    static const json empty = json::array();
    if (!j.contains(key)) return empty;
    if (!j[key].is_array()) throw InputError(where_ + "'" + key + "' is not an array");
    return j[key];
  }

  const json& element(const char* kind, std::size_t index) const {
    const json& a = get_array(doc_, kind);
    if (index >= a.size())
      throw InputError(where_ + std::string(kind) + " index " + std::to_string(index) +
                       " out of range (" + std::to_string(a.size()) + ")");
    return a[index];
  }

  std::span<const std::uint8_t> buffer(std::size_t index) {
    if (buffers_.size() <= index) buffers_.resize(index + 1);
    if (!buffers_[index].empty()) return buffers_[index];
    const json& b = element("buffers", index);
    const std::size_t byte_length = b.at("byteLength").get<std::size_t>();
    std::span<const std::uint8_t> data;
    if (!b.contains("uri")) {
      if (!have_bin_) throw InputError(where_ + "buffer " + std::to_string(index) + " has no data");
      data = bin_;
    } else {
      const std::string uri = b["uri"].get<std::string>();
      if (uri.rfind("data:", 0) == 0) {
        const auto comma = uri.find(";base64,");
        if (comma == std::string::npos) throw InputError(where_ + "data: URI is not base64");
        buffers_[index] = base64_decode(std::string_view(uri).substr(comma + 8), where_);
      } else {
        if (!on_disk_) throw InputError(where_ + "buffer '" + uri + "' is a separate file");
        buffers_[index] = read_file(path_.parent_path() / uri, where_prefix(path_.parent_path() / uri));
      }
      data = buffers_[index];
    }
    if (data.size() < byte_length)
      throw InputError(where_ + "buffer " + std::to_string(index) + " has " +
                       std::to_string(data.size()) + " bytes, byteLength says " +
                       std::to_string(byte_length));
    if (b.contains("uri")) return buffers_[index];
    return data.first(byte_length);
  }

  struct View {
    std::span<const std::uint8_t> bytes;
    std::size_t stride = 0;
  };

  View buffer_view(std::size_t index) {
    const json& v = element("bufferViews", index);
    const std::size_t offset = v.value("byteOffset", std::size_t(0));
    const std::size_t length = v.at("byteLength").get<std::size_t>();
    const auto buf = buffer(v.at("buffer").get<std::size_t>());
    if (offset > buf.size() || length > buf.size() - offset)
      throw InputError(where_ + "bufferView " + std::to_string(index) + " (offset " +
                       std::to_string(offset) + ", length " + std::to_string(length) +
                       ") is beyond its buffer of " + std::to_string(buf.size()) + " bytes");
    return {buf.subspan(offset, length), v.value("byteStride", std::size_t(0))};
  }

  // Reads an accessor as floats (normalized integers are converted), `comps` per element.
  std::vector<float> read_accessor(std::size_t index, int comps, bool allow_ints = false) {
    const json& a = element("accessors", index);
    if (a.contains("sparse")) throw InputError(where_ + "sparse accessors are not supported");
    const std::string type = a.at("type").get<std::string>();
    const int type_comps = type == "SCALAR" ? 1 : type == "VEC2" ? 2 : type == "VEC3" ? 3
                           : type == "VEC4" ? 4 : 0;
    if (type_comps != comps)
      throw InputError(where_ + "accessor " + std::to_string(index) + " has type " + type +
                       ", expected " + std::to_string(comps) + " components");
    const int ct = a.at("componentType").get<int>();
    const std::size_t csize = ct == 5126 || ct == 5125 ? 4 : ct == 5123 || ct == 5122 ? 2
                              : ct == 5121 || ct == 5120 ? 1 : 0;
    if (csize == 0) throw InputError(where_ + "accessor " + std::to_string(index) + ": bad componentType");
    const bool normalized = a.value("normalized", false);
    if (ct != 5126 && !normalized && !allow_ints)
      throw InputError(where_ + "accessor " + std::to_string(index) + " must be float");
    const std::size_t count = a.at("count").get<std::size_t>();
    std::vector<float> out(count * std::size_t(comps), 0.0f);
    if (!a.contains("bufferView")) return out;  // all zeros, as the spec says
    const View v = buffer_view(a["bufferView"].get<std::size_t>());
    const std::size_t offset = a.value("byteOffset", std::size_t(0));
    const std::size_t elem = csize * std::size_t(comps);
    const std::size_t stride = v.stride ? v.stride : elem;
    if (count > 0 && (offset > v.bytes.size() || (count - 1) * stride + elem > v.bytes.size() - offset))
      throw InputError(where_ + "accessor " + std::to_string(index) + " (" + std::to_string(count) +
                       " x " + type + ") out of range of its bufferView of " +
                       std::to_string(v.bytes.size()) + " bytes");
    for (std::size_t i = 0; i < count; ++i)
      for (int c = 0; c < comps; ++c) {
        const std::uint8_t* p = v.bytes.data() + offset + i * stride + std::size_t(c) * csize;
        float x = 0;
        switch (ct) {
          case 5126: std::memcpy(&x, p, 4); break;
          case 5125: { std::uint32_t u; std::memcpy(&u, p, 4); x = float(u); break; }
          case 5123: { std::uint16_t u; std::memcpy(&u, p, 2); x = normalized ? u / 65535.0f : float(u); break; }
          case 5122: { std::int16_t u; std::memcpy(&u, p, 2); x = normalized ? std::max(u / 32767.0f, -1.0f) : float(u); break; }
          case 5121: x = normalized ? *p / 255.0f : float(*p); break;
          default: x = normalized ? std::max(std::int8_t(*p) / 127.0f, -1.0f) : float(std::int8_t(*p)); break;
        }
        out[i * std::size_t(comps) + std::size_t(c)] = x;
      }
    return out;
  }

  std::vector<std::uint32_t> read_indices(std::size_t index) {
    const json& a = element("accessors", index);
    const int ct = a.at("componentType").get<int>();
    if (ct != 5121 && ct != 5123 && ct != 5125)
      throw InputError(where_ + "index accessor " + std::to_string(index) + " must be u8/u16/u32");
    if (a.value("normalized", false)) throw InputError(where_ + "index accessor is normalized");
    const std::vector<float> f = read_accessor(index, 1, true);
    // u32 indices above 2^24 would lose precision through float: read them directly.
    std::vector<std::uint32_t> out(f.size());
    if (ct == 5125) {
      const View v = buffer_view(a.at("bufferView").get<std::size_t>());
      const std::size_t offset = a.value("byteOffset", std::size_t(0)), stride = v.stride ? v.stride : 4;
      for (std::size_t i = 0; i < out.size(); ++i) std::memcpy(&out[i], v.bytes.data() + offset + i * stride, 4);
    } else {
      for (std::size_t i = 0; i < out.size(); ++i) out[i] = std::uint32_t(f[i]);
    }
    return out;
  }

  struct Primitive {
    std::vector<glm::vec3> positions, normals;
    std::vector<glm::vec2> uvs;
    std::vector<glm::vec4> occlusion;  // _OCCLUSION (arlight's baked occlusion, Mesh::occlusion)
    std::vector<float> transfer;       // _SH_TRANSFER_0..2 (Mesh::transfer: 3 VEC3s, 9 per vertex)
    std::vector<std::uint32_t> indices;
  };

#ifdef ARLIGHT_NO_DRACO
  Primitive decode_draco(const json&) {
    throw InputError(where_ +
                     "KHR_draco_mesh_compression: this build has no Draco decoder "
                     "(re-encode the model with `arlight-model convert`)");
  }
#else
  Primitive decode_draco(const json& ext) {
    const View v = buffer_view(ext.at("bufferView").get<std::size_t>());
    draco::DecoderBuffer buf;
    buf.Init(reinterpret_cast<const char*>(v.bytes.data()), v.bytes.size());
    draco::Decoder decoder;
    auto result = decoder.DecodeMeshFromBuffer(&buf);
    if (!result.ok())
      throw InputError(where_ + "Draco decode failure: " + result.status().error_msg_string());
    std::unique_ptr<draco::Mesh> dm = std::move(result).value();
    Primitive p;
    const json attrs = ext.value("attributes", json::object());
    auto read = [&](const char* name, int comps, auto& out) {
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
    read("TEXCOORD_0", 2, p.uvs);
    p.indices.reserve(std::size_t(dm->num_faces()) * 3);
    for (draco::FaceIndex f(0); f < dm->num_faces(); ++f)
      for (int k = 0; k < 3; ++k) p.indices.push_back(dm->face(f)[k].value());
    return p;
  }
#endif  // ARLIGHT_NO_DRACO

  template <typename V>
  std::vector<V> as_vec(const std::vector<float>& f) {
    std::vector<V> out(f.size() * sizeof(float) / sizeof(V));
    std::memcpy(out.data(), f.data(), out.size() * sizeof(V));
    return out;
  }

  Primitive read_primitive(const json& prim) {
    const json attrs = prim.value("attributes", json::object());
    if (prim.contains("extensions") && prim["extensions"].contains("KHR_draco_mesh_compression")) {
      Primitive p = decode_draco(prim["extensions"]["KHR_draco_mesh_compression"]);
      // The glTF accessors describe the decoded data: their counts must agree.
      auto count = [&](std::size_t accessor) {
        return element("accessors", accessor).at("count").get<std::size_t>();
      };
      if (attrs.contains("POSITION") && count(attrs["POSITION"].get<std::size_t>()) != p.positions.size())
        throw InputError(where_ + "Draco decoded " + std::to_string(p.positions.size()) +
                         " vertices, the POSITION accessor says " +
                         std::to_string(count(attrs["POSITION"].get<std::size_t>())));
      if (prim.contains("indices") && count(prim["indices"].get<std::size_t>()) != p.indices.size())
        throw InputError(where_ + "Draco decoded " + std::to_string(p.indices.size()) +
                         " indices, the indices accessor says " +
                         std::to_string(count(prim["indices"].get<std::size_t>())));
      return p;
    }
    Primitive p;
    if (!attrs.contains("POSITION")) throw InputError(where_ + "primitive without POSITION");
    p.positions = as_vec<glm::vec3>(read_accessor(attrs["POSITION"].get<std::size_t>(), 3));
    if (attrs.contains("NORMAL"))
      p.normals = as_vec<glm::vec3>(read_accessor(attrs["NORMAL"].get<std::size_t>(), 3));
    if (attrs.contains("TEXCOORD_0"))
      p.uvs = as_vec<glm::vec2>(read_accessor(attrs["TEXCOORD_0"].get<std::size_t>(), 2));
    if (attrs.contains("_OCCLUSION")) {
      p.occlusion = as_vec<glm::vec4>(read_accessor(attrs["_OCCLUSION"].get<std::size_t>(), 4));
      for (const glm::vec4& o : p.occlusion)
        if (!(o.w >= 0.0f && o.w <= 1.0f) || !std::isfinite(o.x + o.y + o.z))
          throw InputError(where_ +
                           "_OCCLUSION: an occlusion outside [0, 1] or a bent normal not finite");
    }
    if (attrs.contains("_SH_TRANSFER_0")) {
      // Three VEC3 accessors of coefficients 0-2, 3-5 and 6-8; |t_k| <= max |Y_k| < 1.1.
      std::vector<std::vector<float>> parts;
      for (const char* name : {"_SH_TRANSFER_0", "_SH_TRANSFER_1", "_SH_TRANSFER_2"}) {
        if (!attrs.contains(name))
          throw InputError(where_ + name + " missing beside _SH_TRANSFER_0");
        parts.push_back(read_accessor(attrs[name].get<std::size_t>(), 3));
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
    if (prim.contains("indices")) {
      p.indices = read_indices(prim["indices"].get<std::size_t>());
    } else {
      p.indices.resize(p.positions.size() - p.positions.size() % 3);
      for (std::size_t i = 0; i < p.indices.size(); ++i) p.indices[i] = std::uint32_t(i);
    }
    return p;
  }

  void add_mesh(std::size_t mesh_index, const glm::dmat4& world) {
    const json& m = element("meshes", mesh_index);
    const glm::mat4 M(world);
    const glm::mat3 N = glm::inverseTranspose(glm::mat3(M));
    const bool flip = glm::determinant(glm::mat3(M)) < 0.0f;
    for (const json& prim : get_array(m, "primitives")) {
      if (prim.value("mode", 4) != 4) continue;  // points and lines are not drawn
      Primitive p = read_primitive(prim);
      const std::size_t n = p.positions.size();
      if (n == 0) throw InputError(where_ + "primitive without positions");
      if ((!p.normals.empty() && p.normals.size() != n) || (!p.uvs.empty() && p.uvs.size() != n) ||
          (!p.occlusion.empty() && p.occlusion.size() != n) ||
          (!p.transfer.empty() && p.transfer.size() != n * kTransferCoefficients))
        throw InputError(where_ + "primitive attributes have different counts");
      if (p.indices.size() % 3 != 0) throw InputError(where_ + "index count is not a multiple of 3");
      for (std::uint32_t i : p.indices)
        if (i >= n)
          throw InputError(where_ + "index " + std::to_string(i) + " out of range (" +
                           std::to_string(n) + " vertices)");
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
      for (std::size_t i = 0; i < part.indices.size(); i += 3) {
        mesh_.indices.push_back(base + part.indices[i]);
        mesh_.indices.push_back(base + part.indices[i + (flip ? 2 : 1)]);
        mesh_.indices.push_back(base + part.indices[i + (flip ? 1 : 2)]);
      }
    }
  }

  glm::dmat4 local_transform(const json& node) const {
    if (node.contains("matrix")) {
      const auto m = node["matrix"].get<std::vector<double>>();
      if (m.size() != 16) throw InputError(where_ + "node matrix must have 16 numbers");
      return glm::make_mat4(m.data());  // column-major, as glTF stores it
    }
    glm::dmat4 t(1.0);
    if (node.contains("translation")) {
      const auto v = node["translation"].get<std::vector<double>>();
      if (v.size() != 3) throw InputError(where_ + "node translation must have 3 numbers");
      t[3] = glm::dvec4(v[0], v[1], v[2], 1.0);
    }
    glm::dmat4 r(1.0);
    if (node.contains("rotation")) {
      const auto q = node["rotation"].get<std::vector<double>>();  // x, y, z, w
      if (q.size() != 4) throw InputError(where_ + "node rotation must have 4 numbers");
      r = glm::mat4_cast(glm::normalize(glm::dquat(q[3], q[0], q[1], q[2])));
    }
    glm::dmat4 s(1.0);
    if (node.contains("scale")) {
      const auto v = node["scale"].get<std::vector<double>>();
      if (v.size() != 3) throw InputError(where_ + "node scale must have 3 numbers");
      s[0][0] = v[0], s[1][1] = v[1], s[2][2] = v[2];
    }
    return t * r * s;
  }

  void visit(int index, const glm::dmat4& parent, int depth) {
    if (depth > 64) throw InputError(where_ + "node hierarchy deeper than 64 (a cycle?)");
    if (index < 0) throw InputError(where_ + "negative node index");
    const json& node = element("nodes", std::size_t(index));
    const glm::dmat4 world = parent * local_transform(node);
    if (node.contains("mesh")) add_mesh(node["mesh"].get<std::size_t>(), world);
    for (const json& c : node.value("children", json::array())) visit(c.get<int>(), world, depth + 1);
  }

  std::filesystem::path path_;
  std::string where_;
  std::vector<std::uint8_t> file_;
  json doc_;
  std::span<const std::uint8_t> bin_;
  bool have_bin_ = false;
  std::vector<std::vector<std::uint8_t>> buffers_;
  bool on_disk_ = true;  // separate buffer files resolve next to path_
  Mesh mesh_;
  bool has_uvs_ = false, has_occlusion_ = false, has_transfer_ = false;
};

}  // namespace

Mesh load_gltf(const std::filesystem::path& path) {
  try {
    return GltfReader(path).load();
  } catch (const json::exception& e) {
    // Wrong types or missing required keys in otherwise valid JSON.
    throw InputError(where_prefix(path) + "malformed glTF: " + e.what());
  }
}

Mesh load_gltf(std::span<const std::uint8_t> bytes, const std::string& name) {
  try {
    return GltfReader(std::vector<std::uint8_t>(bytes.begin(), bytes.end()), name, false).load();
  } catch (const json::exception& e) {
    throw InputError(where_prefix(name) + "malformed glTF: " + e.what());
  }
}

std::vector<std::uint8_t> encode_glb(const Mesh& mesh) {
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
  const std::size_t indices = append(mesh.indices.data(), mesh.indices.size() * 4, kElementArrayBuffer,
                                     kUint, mesh.indices.size(), "SCALAR");
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
      {"meshes",
       json::array(
           {{{"primitives",
              json::array({{{"attributes", attributes}, {"indices", indices}, {"mode", 4}}})}}})},
      {"buffers", json::array({{{"byteLength", bin.size()}}})},
      {"bufferViews", views},
      {"accessors", accessors}};
  if (!extras.empty()) doc["extras"] = std::move(extras);
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
