#include "gltf_materials.hpp"

#include <stb_image.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <memory>
#include <sstream>
#include <stdexcept>

#include "arlight/common/error.hpp"

namespace arlight::render::gltf_detail {

namespace {

constexpr int kMaxTextureSide = 8192;

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

class MaterialReader {
 public:
  MaterialReader(const GltfDocument& doc, bool decode) : doc_(doc), decode_(decode) {}

  GltfMaterials read() && {
    for (std::size_t i = 0; i < doc_.model.materials.size(); ++i) {
      MaterialUv uv;
      Material m = read_material(i, uv);
      out_.uv.push_back(uv);
      if (decode_) {
        out_.materials.push_back(std::move(m));
        out_.names.push_back(doc_.model.materials[i].name);
      }
    }
    if (!decode_) out_.warnings.clear();  // they are about what is drawn
    return std::move(out_);
  }

 private:
  Material read_material(std::size_t index, MaterialUv& uv) {
    const tinygltf::Material& g = doc_.model.materials[index];
    const std::string what = material_where(doc_, index);
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
        out_.warnings.push_back(what + "extension " + name + " is not supported (ignored)");
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
      if (std::size_t(info.index) >= doc_.model.textures.size())
        throw InputError(f + "texture " + std::to_string(info.index) + " out of range (" +
                         std::to_string(doc_.model.textures.size()) + ")");
      const tinygltf::Texture& t = doc_.model.textures[std::size_t(info.index)];
      if (t.source < 0 || std::size_t(t.source) >= doc_.model.images.size())
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
      return decode_ ? image(std::size_t(t.source), srgb, f) : nullptr;
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
    const tinygltf::Image& im = doc_.model.images[index];
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

  const GltfDocument& doc_;
  const bool decode_;
  GltfMaterials out_;
  std::map<std::pair<std::size_t, bool>, std::shared_ptr<const TextureImage>> images_;
};

}  // namespace

GltfMaterials read_materials(const GltfDocument& doc, bool decode) {
  return MaterialReader(doc, decode).read();
}

std::string material_where(const GltfDocument& doc, std::size_t index) {
  std::string s = doc.where + "material " + std::to_string(index);
  if (!doc.model.materials[index].name.empty()) s.append(" '").append(doc.model.materials[index].name).append("'");
  return s + ": ";
}

}  // namespace arlight::render::gltf_detail
