// Internal: a glTF file read into tinygltf's document (the JSON, its buffers from the GLB chunk,
// data: URIs or files beside the model, and its images' encoded bytes), which gltf.cpp reads the
// geometry of and gltf_materials.cpp the materials of. tinygltf leaves bounds to its caller:
// the GLB container is checked before it reads, and every accessor by gltf.cpp.
#pragma once

#include <cstdint>
#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <utility>
#include <vector>

#include "tiny_gltf.hpp"

namespace arlight::render::gltf_detail {

using json = nlohmann::json;

struct GltfDocument {
  std::string where;  // "'<file>': ", the prefix of every message
  tinygltf::Model model;
  // KHR_draco_mesh_compression primitives whose indices accessor has no bufferView (tinygltf
  // 2.7 refuses them, so they lose "indices" before it reads): by (mesh, primitive), the count
  // that accessor gave, to check the decoded mesh against.
  std::map<std::pair<std::size_t, std::size_t>, std::size_t> draco_indices;
};

std::vector<std::uint8_t> read_file(const std::filesystem::path& path, const std::string& where);
// "'<path>': "
std::string where_prefix(const std::filesystem::path& path);

// Reads `bytes` (GLB or glTF JSON; `name` for messages and, with `on_disk`, the folder of the
// files it names) into `doc`, which is filled in place (tinygltf's image callback checks an
// image's bufferView against the buffers already read). Throws InputError naming the file.
void read_document(const std::vector<std::uint8_t>& bytes, const std::filesystem::path& name,
                   bool on_disk, GltfDocument& doc);

// An object's extensions as tinygltf kept them (extensions_json_string), parsed; {} if none.
json parse_extensions(const std::string& text, const std::string& where);

}  // namespace arlight::render::gltf_detail
