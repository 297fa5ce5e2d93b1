#include "gltf_document.hpp"

#include <cstring>
#include <fstream>
#include <span>

#include "arlight/common/error.hpp"

namespace arlight::render::gltf_detail {

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

namespace {

constexpr std::uint32_t kGlbMagic = 0x46546C67;  // "glTF"
constexpr std::uint32_t kChunkJson = 0x4E4F534A;

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

// tinygltf 2.7 refuses a primitive whose indices accessor has no bufferView, which is how
// KHR_draco_mesh_compression files are written (the indices are in the Draco stream; tinygltf's
// own Draco option is not built). Such primitives lose "indices" before tinygltf reads the
// document (the JSON rewritten, a GLB's other chunks as they were); the counts those accessors
// gave, by (mesh, primitive), are kept to check the decoded meshes against.
using DracoIndexCounts = decltype(GltfDocument::draco_indices);
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

}  // namespace

void read_document(const std::vector<std::uint8_t>& bytes, const std::filesystem::path& name,
                   bool on_disk, GltfDocument& doc) {
  doc.where = where_prefix(name);
  const std::string& where = doc.where;
  FileAccess files{on_disk};
  tinygltf::TinyGLTF loader;
  loader.SetImageLoader(&keep_encoded_image, &doc.model);
  loader.SetFsCallbacks(
      tinygltf::FsCallbacks{&file_exists, &expand_path, &read_whole_file, &write_whole_file, &files});
  loader.SetStoreOriginalJSONForExtrasAndExtensions(true);
  const std::string base = on_disk ? name.parent_path().string() : std::string();
  std::string err, warn;
  bool ok = false;
  if (bytes.size() >= 4 && u32(bytes.data()) == kGlbMagic) {
    check_glb(bytes, where);
    const std::vector<std::uint8_t> glb = draco_indices_moved(bytes, true, doc.draco_indices, where);
    ok = loader.LoadBinaryFromMemory(&doc.model, &err, &warn, glb.data(), unsigned(glb.size()), base);
  } else if (name.extension() == ".glb") {
    throw InputError(where + "bad magic: not a binary glTF (.glb) file");
  } else {
    const std::vector<std::uint8_t> text = draco_indices_moved(bytes, false, doc.draco_indices, where);
    ok = loader.LoadASCIIFromString(&doc.model, &err, &warn, reinterpret_cast<const char*>(text.data()),
                                    unsigned(text.size()), base);
  }
  while (!err.empty() && err.back() == '\n') err.pop_back();
  if (!ok) throw InputError(where + "invalid glTF: " + (err.empty() ? "unreadable" : err));
  if (doc.model.asset.version.rfind("2.", 0) != 0)
    throw InputError(where + "not glTF 2.0 (asset.version)");
  for (const std::string& e : doc.model.extensionsRequired)
    if (e != "KHR_draco_mesh_compression" && e != "KHR_texture_transform" &&
        e != "KHR_materials_emissive_strength")
      throw InputError(where + "unsupported required extension \"" + e + "\"");
}

json parse_extensions(const std::string& text, const std::string& where) {
  if (text.empty()) return json::object();
  try {
    json j = json::parse(text);
    if (!j.is_object()) throw InputError(where + "extensions is not an object");
    return j;
  } catch (const json::exception& e) {
    throw InputError(where + "extensions: " + e.what());
  }
}

}  // namespace arlight::render::gltf_detail
