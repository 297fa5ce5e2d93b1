// glTF 2.0 loading: the Draco-compressed sample models, a hand-made .gltf with an embedded
// buffer and a node transform, and malformed files that must raise InputError naming the file.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <glm/geometric.hpp>
#include <nlohmann/json.hpp>

#include "arlight/common/error.hpp"
#include "arlight/render/gltf.hpp"
#include "arlight/render/sample_models.hpp"

namespace arlight::render {
namespace {

const std::filesystem::path kModels = std::filesystem::path(ARLIGHT_ASSETS_DIR) / "models";

void expect_sane(const Mesh& m) {
  ASSERT_EQ(m.normals.size(), m.positions.size());
  EXPECT_GT(m.triangle_count(), 1000u);
  for (std::uint32_t i : m.indices) ASSERT_LT(i, m.vertex_count());
  for (const glm::vec3& n : m.normals) ASSERT_NEAR(glm::length(n), 1.0f, 1e-3f);
  const glm::vec3 size = m.bounds.size();
  for (int a = 0; a < 3; ++a) {
    EXPECT_TRUE(std::isfinite(m.bounds.min[a]) && std::isfinite(m.bounds.max[a]));
    EXPECT_GT(size[a], 0.0f);
  }
  // Bounds enclose every vertex and are tight.
  glm::vec3 lo(1e30f), hi(-1e30f);
  for (const glm::vec3& p : m.positions) lo = glm::min(lo, p), hi = glm::max(hi, p);
  EXPECT_EQ(lo, m.bounds.min);
  EXPECT_EQ(hi, m.bounds.max);
}

// assets/README.md's "16,944 / 44,526 vertices" are the index counts (triangle corners): libdraco
// decodes 2,826 / 7,503 shared vertices, as the files' POSITION accessors say.
TEST(Gltf, BunnyLoadsWithTheDocumentedCounts) {
  const Mesh m = load_gltf(kModels / "bunny.glb");
  EXPECT_EQ(m.indices.size(), 16944u);
  EXPECT_EQ(m.vertex_count(), 2826u);
  // The POSITION accessor's min / max, to Draco's quantisation step.
  EXPECT_NEAR(m.bounds.min.x, -0.9137708f, 2e-4f);
  EXPECT_NEAR(m.bounds.max.y, 0.9398829f, 2e-4f);
  EXPECT_NEAR(m.bounds.min.z, -0.6963724f, 2e-4f);
  EXPECT_TRUE(m.uvs.empty());
  EXPECT_TRUE(m.tangents.empty());
  expect_sane(m);
  // A bunny is not a pancake: the longest side is at most a few times the shortest.
  const glm::vec3 s = m.bounds.size();
  EXPECT_LT(std::max({s.x, s.y, s.z}) / std::min({s.x, s.y, s.z}), 4.0f);
}

TEST(Gltf, SuzanneLoadsWithTheDocumentedCounts) {
  const Mesh m = load_gltf(kModels / "suzi.glb");
  EXPECT_EQ(m.indices.size(), 44526u);
  EXPECT_EQ(m.vertex_count(), 7503u);
  EXPECT_NEAR(m.bounds.max.x, 0.9297301f, 2e-4f);
  EXPECT_NEAR(m.bounds.min.y, -0.6697948f, 2e-4f);
  expect_sane(m);
}

std::filesystem::path temp_file(const std::string& name, const std::string& bytes) {
  const auto p = std::filesystem::temp_directory_path() /
                 ("arlight_gltf_" + std::to_string(::getpid()) + "_" + name);
  std::ofstream(p, std::ios::binary) << bytes;
  return p;
}

std::string read_bytes(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), {}};
}

// The GLB's JSON, edited by `edit`, put back (the binary chunk as it was).
std::vector<std::uint8_t> with_json(const std::vector<std::uint8_t>& glb,
                                    const std::function<void(nlohmann::json&)>& edit) {
  std::uint32_t json_len;
  std::memcpy(&json_len, glb.data() + 12, 4);
  nlohmann::json doc = nlohmann::json::parse(glb.begin() + 20, glb.begin() + 20 + json_len);
  edit(doc);
  std::string text = doc.dump();
  while (text.size() % 4) text += ' ';
  std::vector<std::uint8_t> out(glb.begin(), glb.begin() + 12);
  const auto u32 = [&](std::uint32_t v) {
    for (int i = 0; i < 4; ++i) out.push_back(std::uint8_t(v >> (8 * i)));
  };
  u32(std::uint32_t(text.size())), u32(0x4E4F534Au);
  out.insert(out.end(), text.begin(), text.end());
  out.insert(out.end(), glb.begin() + 20 + json_len, glb.end());
  const std::uint32_t total = std::uint32_t(out.size());
  std::memcpy(out.data() + 8, &total, 4);
  return out;
}

void expect_input_error(const std::filesystem::path& p, const std::string& what) {
  try {
    load_gltf(p);
    ADD_FAILURE() << "no error for " << p;
  } catch (const InputError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find(p.string()), std::string::npos) << m;
    EXPECT_NE(m.find(what), std::string::npos) << m;
  }
  std::filesystem::remove(p);
}

TEST(Gltf, MalformedFilesRaiseInputErrorNamingTheFile) {
  const std::string bunny = read_bytes(kModels / "bunny.glb");
  ASSERT_GT(bunny.size(), 1000u);
  expect_input_error(temp_file("garbage.glb", std::string(500, 'x')), "bad magic");
  expect_input_error(temp_file("header.glb", bunny.substr(0, 8)), "truncated");
  // Cut in half: the header's length (and the BIN chunk) reach beyond the file.
  expect_input_error(temp_file("half.glb", bunny.substr(0, bunny.size() / 2)), "bytes but the file has");
  std::string lying = bunny.substr(0, bunny.size() / 2);
  const std::uint32_t len = std::uint32_t(lying.size());
  std::memcpy(lying.data() + 8, &len, 4);  // a header that matches the cut file
  expect_input_error(temp_file("chunk.glb", lying), "extends beyond the file");
  // Corrupt the Draco stream's header in the BIN chunk (after the JSON chunk).
  std::string corrupt = bunny;
  std::uint32_t json_len;
  std::memcpy(&json_len, corrupt.data() + 12, 4);
  const std::size_t bin = 12 + 8 + json_len + 8;
  for (std::size_t i = bin; i < bin + 64 && i < corrupt.size(); ++i) corrupt[i] = char(0xA5);
  expect_input_error(temp_file("draco.glb", corrupt), "Draco");
  expect_input_error(temp_file("missing.glb", ""), "bad magic");
  EXPECT_THROW(load_gltf("/nonexistent/arlight.glb"), InputError);
}

// One triangle with uvs in an embedded base64 buffer, under a translated and scaled node.
TEST(Gltf, EmbeddedBufferNodeTransformAndTangents) {
  // positions (0,0,0) (1,0,0) (0,1,0); normals +Z; uvs (0,1) (1,1) (0,0); indices 0 1 2 (u16).
  std::string bin;
  auto put = [&](auto v) { bin.append(reinterpret_cast<const char*>(&v), sizeof v); };
  for (float f : {0.f, 0.f, 0.f, 1.f, 0.f, 0.f, 0.f, 1.f, 0.f}) put(f);
  for (int i = 0; i < 3; ++i) put(0.f), put(0.f), put(1.f);
  for (float f : {0.f, 1.f, 1.f, 1.f, 0.f, 0.f}) put(f);
  for (std::uint16_t i : {0, 1, 2}) put(i);
  static const char* b64 = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string enc;
  for (std::size_t i = 0; i < bin.size(); i += 3) {
    const std::uint32_t v = (std::uint8_t(bin[i]) << 16) |
                            (i + 1 < bin.size() ? std::uint8_t(bin[i + 1]) << 8 : 0) |
                            (i + 2 < bin.size() ? std::uint8_t(bin[i + 2]) : 0);
    enc += b64[(v >> 18) & 63], enc += b64[(v >> 12) & 63];
    enc += i + 1 < bin.size() ? b64[(v >> 6) & 63] : '=';
    enc += i + 2 < bin.size() ? b64[v & 63] : '=';
  }
  auto gltf = [&](int index_count) {
    return R"({"asset":{"version":"2.0"},"scene":0,"scenes":[{"nodes":[0]}],
      "nodes":[{"mesh":0,"translation":[1,2,3],"scale":[2,2,2]}],
      "meshes":[{"primitives":[{"attributes":{"POSITION":0,"NORMAL":1,"TEXCOORD_0":2},"indices":3}]}],
      "buffers":[{"byteLength":)" + std::to_string(bin.size()) +
           R"(,"uri":"data:application/octet-stream;base64,)" + enc + R"("}],
      "bufferViews":[{"buffer":0,"byteOffset":0,"byteLength":36},{"buffer":0,"byteOffset":36,"byteLength":36},
                     {"buffer":0,"byteOffset":72,"byteLength":24},{"buffer":0,"byteOffset":96,"byteLength":6}],
      "accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3"},
                   {"bufferView":1,"componentType":5126,"count":3,"type":"VEC3"},
                   {"bufferView":2,"componentType":5126,"count":3,"type":"VEC2"},
                   {"bufferView":3,"componentType":5123,"count":)" + std::to_string(index_count) + R"(,"type":"SCALAR"}]})";
  };
  const auto p = temp_file("tri.gltf", gltf(3));
  const Mesh m = load_gltf(p);
  std::filesystem::remove(p);
  ASSERT_EQ(m.vertex_count(), 3u);
  EXPECT_EQ(m.positions[1], glm::vec3(3, 2, 3));  // 2 * (1,0,0) + (1,2,3)
  EXPECT_EQ(m.positions[2], glm::vec3(1, 4, 3));
  EXPECT_EQ(m.bounds.min, glm::vec3(1, 2, 3));
  ASSERT_EQ(m.tangents.size(), 3u);
  // u grows along +x; v grows downwards (-y), so the bitangent (up the image) is +y: w = +1.
  EXPECT_NEAR(glm::distance(glm::vec3(m.tangents[0]), glm::vec3(1, 0, 0)), 0.0f, 1e-6f);
  EXPECT_EQ(m.tangents[0].w, 1.0f);
  // An index accessor that claims more elements than its bufferView holds.
  expect_input_error(temp_file("range.gltf", gltf(4)), "out of range");
}

}  // namespace
// The browser client's copies (arlight-model convert): a plain GLB read back from memory gives
// the same mesh (normals to a rounding: the loader renormalises them); one with uvs keeps them; a separate-file buffer is refused there.
TEST(Gltf, EncodedGlbReadsBackFromMemoryAsTheSameMesh) {
  for (const char* name : {"bunny.glb", "suzi.glb"}) {
    const Mesh m = load_gltf(kModels / name);
    const std::vector<std::uint8_t> glb = encode_glb(m);
    ASSERT_EQ(glb.size() % 4, 0u);
    const Mesh back = load_gltf(glb, name);
    EXPECT_EQ(back.positions, m.positions) << name;
    ASSERT_EQ(back.normals.size(), m.normals.size());
    for (std::size_t i = 0; i < m.normals.size(); ++i)
      ASSERT_LT(glm::length(back.normals[i] - m.normals[i]), 1e-6f) << name << " normal " << i;
    EXPECT_EQ(back.indices, m.indices) << name;
    EXPECT_EQ(back.bounds.min, m.bounds.min);
    EXPECT_EQ(back.bounds.max, m.bounds.max);
  }
  const Mesh sphere = make_sphere(0.5f, 8, 16);
  const Mesh back = load_gltf(encode_glb(sphere), "sphere.glb");
  EXPECT_EQ(back.uvs, sphere.uvs);
  EXPECT_EQ(back.tangents.size(), sphere.positions.size());  // recomputed from the uvs

  const std::string gltf = R"({"asset": {"version": "2.0"}, "buffers": [{"uri": "mesh.bin", "byteLength": 36}],
    "bufferViews": [{"buffer": 0, "byteLength": 36}],
    "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3"}],
    "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}], "nodes": [{"mesh": 0}]})";
  const std::vector<std::uint8_t> bytes(gltf.begin(), gltf.end());
  try {
    load_gltf(bytes, "page.gltf");
    FAIL() << "a separate buffer file was read from memory";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("'page.gltf'"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("mesh.bin"), std::string::npos) << e.what();
  }
  // The baked occlusion (arlight's _OCCLUSION attribute) travels with the model to the page.
  Mesh baked = sphere;
  for (std::size_t i = 0; i < baked.positions.size(); ++i)
    baked.occlusion.push_back(glm::vec4(baked.normals[i], float(i % 7) / 7.0f));
  const Mesh baked_back = load_gltf(encode_glb(baked), "baked.glb");
  ASSERT_EQ(baked_back.occlusion.size(), baked.occlusion.size());
  for (std::size_t i = 0; i < baked.occlusion.size(); ++i)
    ASSERT_LT(glm::length(baked_back.occlusion[i] - baked.occlusion[i]), 1e-6f) << i;
  // An occlusion outside [0, 1] is a bad file, named.
  baked.occlusion[3].w = 1.5f;
  try {
    load_gltf(encode_glb(baked), "bad_occlusion.glb");
    FAIL() << "an occlusion of 1.5 was taken";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("_OCCLUSION"), std::string::npos) << e.what();
  }
  baked.occlusion.pop_back();
  EXPECT_THROW(encode_glb(baked), std::invalid_argument);

  // And the SH-9 transfer (_SH_TRANSFER_0..2), coefficient for coefficient; a coefficient out of
  // range is a bad file, named; one short is refused when writing.
  Mesh transferred = sphere;
  for (std::size_t i = 0; i < transferred.positions.size() * kTransferCoefficients; ++i)
    transferred.transfer.push_back(float(int(i % 23) - 11) / 12.0f);
  const Mesh transferred_back = load_gltf(encode_glb(transferred), "transfer.glb");
  ASSERT_EQ(transferred_back.transfer.size(), transferred.transfer.size());
  for (std::size_t i = 0; i < transferred.transfer.size(); ++i)
    ASSERT_EQ(transferred_back.transfer[i], transferred.transfer[i]) << i;
  transferred.transfer[13] = 5.0f;
  try {
    load_gltf(encode_glb(transferred), "bad_transfer.glb");
    FAIL() << "a transfer coefficient of 5 was taken";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("_SH_TRANSFER_1"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("bad_transfer.glb"), std::string::npos) << e.what();
  }
  transferred.transfer.pop_back();
  EXPECT_THROW(encode_glb(transferred), std::invalid_argument);

  // So does the baked floor (extras.arlight_ground).
  Mesh floored = sphere;
  floored.ground = {{-1.5f, -1.0f}, {1.5f, 2.0f}, 4, {}, {}};
  for (int i = 0; i < 16; ++i) floored.ground.occluded.push_back(float(i) / 16.0f);
  const Mesh floored_back = load_gltf(encode_glb(floored), "floored.glb");
  EXPECT_EQ(floored_back.ground.min, floored.ground.min);
  EXPECT_EQ(floored_back.ground.max, floored.ground.max);
  EXPECT_EQ(floored_back.ground.size, 4);
  EXPECT_EQ(floored_back.ground.occluded, floored.ground.occluded);
  floored.ground.occluded[5] = -0.5f;
  try {
    load_gltf(encode_glb(floored), "bad_ground.glb");
    FAIL() << "a floor occlusion of -0.5 was taken";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("arlight_ground"), std::string::npos) << e.what();
  }

  Mesh broken = sphere;
  broken.indices.push_back(9999);
  broken.indices.push_back(0);
  broken.indices.push_back(1);
  EXPECT_THROW(encode_glb(broken), std::invalid_argument);
}

}  // namespace arlight::render

namespace arlight::render {
namespace {

// A node's rotation turns a primitive's SH-9 transfer with its normals: a transfer leaning
// towards +z (band 1's z coefficient) under a node turned 90 degrees about +y leans towards +x;
// band 0 is unchanged and the band-2 norm is kept.
TEST(Gltf, ANodesRotationTurnsTheTransferWithTheNormals) {
  Mesh tri;
  tri.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  tri.normals.assign(3, glm::vec3(0, 0, 1));
  tri.indices = {0, 1, 2};
  const std::vector<float> t = {0.28f, 0.0f, 0.33f, 0.0f, 0.1f, 0.0f, 0.12f, 0.0f, -0.05f};
  for (int v = 0; v < 3; ++v) tri.transfer.insert(tri.transfer.end(), t.begin(), t.end());
  // A rotation on the node (glTF: [x, y, z, w]).
  const std::vector<std::uint8_t> out = with_json(encode_glb(tri), [](nlohmann::json& doc) {
    doc["nodes"][0]["rotation"] = {0.0, std::sqrt(0.5), 0.0, std::sqrt(0.5)};
  });

  const Mesh back = load_gltf(out, "rotated.glb");
  ASSERT_EQ(back.transfer.size(), 27u);
  EXPECT_NEAR(back.normals[0].x, 1.0f, 1e-6f);  // +z turned to +x
  const float* r = back.transfer.data();
  EXPECT_NEAR(r[0], 0.28f, 1e-6f);
  EXPECT_NEAR(r[1], 0.0f, 1e-6f);   // y
  EXPECT_NEAR(r[2], 0.0f, 1e-6f);   // z
  EXPECT_NEAR(r[3], 0.33f, 1e-6f);  // x
  double before = 0, after = 0;
  for (int k = 4; k < 9; ++k)
    before += double(t[std::size_t(k)]) * t[std::size_t(k)], after += double(r[k]) * r[k];
  EXPECT_NEAR(after, before, 1e-6);
}

}  // namespace
}  // namespace arlight::render

namespace arlight::render {
namespace {

std::string load_error(const std::vector<std::uint8_t>& glb) {
  try {
    load_gltf_model(glb, "model.glb");
  } catch (const InputError& e) {
    return e.what();
  }
  return "(loaded)";
}

// arlight's textured test model written with its materials and read back: two parts with their
// materials, every factor, and every texture texel for texel (PNG is lossless) in the colour
// space its field asks for.
TEST(GltfMaterials, TheTiledBallReadsBackWithItsMaterialsAndTextures) {
  const GltfModel made = make_tiled_ball(64);
  const GltfModel back = load_gltf_model(encode_glb(made), "tiles.glb");
  EXPECT_TRUE(back.warnings.empty());
  EXPECT_EQ(back.material_names, made.material_names);
  ASSERT_EQ(back.materials.size(), 2u);
  ASSERT_EQ(back.mesh.parts.size(), 2u);
  for (std::size_t i = 0; i < 2; ++i) {
    EXPECT_EQ(back.mesh.parts[i].material, int(i));
    EXPECT_EQ(back.mesh.parts[i].first_index, made.mesh.parts[i].first_index);
    EXPECT_EQ(back.mesh.parts[i].index_count, made.mesh.parts[i].index_count);
  }
  EXPECT_EQ(back.mesh.indices, made.mesh.indices);
  const Material& tiles = back.materials[0];
  ASSERT_TRUE(tiles.pbr && tiles.albedo && tiles.pbr->metallic_roughness && tiles.normal_map &&
              tiles.pbr->occlusion);
  EXPECT_TRUE(tiles.albedo->srgb);
  EXPECT_FALSE(tiles.pbr->metallic_roughness->srgb);
  EXPECT_FALSE(tiles.normal_map->srgb);
  EXPECT_EQ(tiles.albedo->u8, made.materials[0].albedo->u8);
  EXPECT_EQ(tiles.pbr->metallic_roughness->u8, made.materials[0].pbr->metallic_roughness->u8);
  EXPECT_EQ(tiles.normal_map->u8, made.materials[0].normal_map->u8);
  EXPECT_EQ(tiles.pbr->occlusion->u8, made.materials[0].pbr->occlusion->u8);
  const Material& glaze = back.materials[1];
  ASSERT_TRUE(glaze.pbr);
  EXPECT_FALSE(glaze.albedo);
  EXPECT_EQ(glaze.pbr->base_colour, made.materials[1].pbr->base_colour);
  EXPECT_EQ(glaze.pbr->metallic, 0.0f);
  EXPECT_FLOAT_EQ(glaze.pbr->roughness, 0.15f);
  // The geometry alone: the parts keep their material indices, nothing decoded.
  const Mesh geometry = load_gltf(encode_glb(made.mesh, made.materials), "tiles.glb");
  ASSERT_EQ(geometry.parts.size(), 2u);
  EXPECT_EQ(geometry.parts[1].material, 1);
}

// Bad or unsupported material parts: an error naming the material and the field, or (for what
// is read but drawn otherwise) a warning naming them; the factors' extensions and a second uv
// set are read.
TEST(GltfMaterials, ProblemsNameTheMaterialAndTheField) {
  const GltfModel made = make_tiled_ball(32);
  const std::vector<std::uint8_t> glb = encode_glb(made.mesh, made.materials);
  const auto error_after = [&](const std::function<void(nlohmann::json&)>& edit) {
    return load_error(with_json(glb, edit));
  };
  std::string e = error_after([](nlohmann::json& d) {
    d["materials"][1]["name"] = "glaze";
    d["materials"][1]["pbrMetallicRoughness"]["roughnessFactor"] = 1.5;
  });
  EXPECT_NE(e.find("material 1 'glaze'"), std::string::npos) << e;
  EXPECT_NE(e.find("roughnessFactor 1.5 is outside [0, 1]"), std::string::npos) << e;
  e = error_after([](nlohmann::json& d) { d["materials"][0]["alphaMode"] = "SOMETIMES"; });
  EXPECT_NE(e.find("material 0: alphaMode 'SOMETIMES'"), std::string::npos) << e;
  e = error_after([](nlohmann::json& d) {
    d["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"]["index"] = 9;
  });
  EXPECT_NE(e.find("baseColorTexture: texture 9 out of range"), std::string::npos) << e;
  e = error_after([](nlohmann::json& d) { d["materials"][0]["normalTexture"]["texCoord"] = 2; });
  EXPECT_NE(e.find("normalTexture: texCoord 2"), std::string::npos) << e;
  e = error_after([](nlohmann::json& d) {
    d["materials"][0]["occlusionTexture"]["extensions"]["KHR_texture_transform"] = {{"scale", {2, 2}}};
  });
  EXPECT_NE(e.find("occlusionTexture: its KHR_texture_transform differs"), std::string::npos) << e;
  e = error_after([](nlohmann::json& d) { d["materials"][0]["emissiveFactor"] = {1, 2}; });
  EXPECT_NE(e.find("emissiveFactor"), std::string::npos) << e;
  // An image whose bytes are not an image: named with the field that uses it.
  std::vector<std::uint8_t> corrupt = glb;
  {
    std::uint32_t json_len;
    std::memcpy(&json_len, glb.data() + 12, 4);
    const nlohmann::json doc = nlohmann::json::parse(glb.begin() + 20, glb.begin() + 20 + json_len);
    const nlohmann::json& view = doc["bufferViews"][doc["images"][0]["bufferView"].get<std::size_t>()];
    const std::size_t at = 20 + json_len + 8 + view["byteOffset"].get<std::size_t>();
    for (std::size_t i = at; i < at + 32; ++i) corrupt[i] = 0x5A;
  }
  e = load_error(corrupt);
  EXPECT_NE(e.find("baseColorTexture: image 0 cannot be decoded"), std::string::npos) << e;
  EXPECT_NO_THROW(load_gltf(corrupt, "model.glb"));  // the geometry alone decodes no image

  // Read but not drawn (an extension it does not know): a warning; BLEND read.
  const GltfModel warned = load_gltf_model(with_json(glb, [](nlohmann::json& d) {
    d["materials"][1]["alphaMode"] = "BLEND";
    d["materials"][1]["extensions"]["KHR_materials_clearcoat"] = {{"clearcoatFactor", 1}};
  }), "model.glb");
  ASSERT_EQ(warned.warnings.size(), 1u);
  EXPECT_NE(warned.warnings[0].find("material 1: extension KHR_materials_clearcoat"), std::string::npos);
  EXPECT_TRUE(warned.materials[1].pbr->alpha_blend);
  EXPECT_FALSE(warned.materials[1].pbr->alpha_mask);
  EXPECT_TRUE(load_gltf_model(encode_glb(warned), "back.glb").materials[1].pbr->alpha_blend);

  // KHR_materials_emissive_strength scales the factor; MASK keeps its cutoff.
  const GltfModel glowing = load_gltf_model(with_json(glb, [](nlohmann::json& d) {
    d["materials"][1]["emissiveFactor"] = {1.0, 0.5, 0.0};
    d["materials"][1]["extensions"]["KHR_materials_emissive_strength"] = {{"emissiveStrength", 4.0}};
    d["materials"][1]["alphaMode"] = "MASK";
    d["materials"][1]["alphaCutoff"] = 0.25;
  }), "model.glb");
  EXPECT_EQ(glowing.materials[1].pbr->emissive, glm::vec3(4.0f, 2.0f, 0.0f));
  EXPECT_TRUE(glowing.materials[1].pbr->alpha_mask);
  EXPECT_EQ(glowing.materials[1].pbr->alpha_cutoff, 0.25f);
  // And back through the writer (factors above 1 as the extension).
  const GltfModel again = load_gltf_model(encode_glb(glowing.mesh, glowing.materials), "again.glb");
  EXPECT_EQ(again.materials[1].pbr->emissive, glm::vec3(4.0f, 2.0f, 0.0f));
}

// One KHR_texture_transform and TEXCOORD_1 for all of a material's textures: applied to the uvs
// of its primitives (u' = sx u + ox with no rotation).
TEST(GltfMaterials, TheMaterialsUvSetAndTransformReachTheUvs) {
  const GltfModel made = make_tiled_ball(16);
  const std::vector<std::uint8_t> glb = encode_glb(made.mesh, made.materials);
  const nlohmann::json transform = {{"offset", {0.25, 0.5}}, {"scale", {2.0, 3.0}}};
  const GltfModel moved = load_gltf_model(with_json(glb, [&](nlohmann::json& d) {
    for (const char* field : {"normalTexture", "occlusionTexture"})
      d["materials"][0][field]["extensions"]["KHR_texture_transform"] = transform;
    for (const char* field : {"baseColorTexture", "metallicRoughnessTexture"})
      d["materials"][0]["pbrMetallicRoughness"][field]["extensions"]["KHR_texture_transform"] = transform;
  }), "moved.glb");
  const std::uint32_t ball = moved.mesh.parts[0].index_count;
  const std::uint32_t v = moved.mesh.indices[ball / 2];  // a vertex of the ball (material 0)
  EXPECT_NEAR(moved.mesh.uvs[v].x, 2.0f * made.mesh.uvs[v].x + 0.25f, 1e-5f);
  EXPECT_NEAR(moved.mesh.uvs[v].y, 3.0f * made.mesh.uvs[v].y + 0.5f, 1e-5f);
  // The plinth's material reads no textures: its primitive keeps the uvs as they were (its own
  // copy of the shared vertices, after the ball's).
  const std::size_t n = made.mesh.vertex_count();
  const std::uint32_t w = moved.mesh.indices[moved.mesh.parts[1].first_index];
  ASSERT_GE(w, n);
  EXPECT_EQ(moved.mesh.uvs[w], made.mesh.uvs[w - n]);

  // TEXCOORD_1 asked for but missing: named; present (the same accessor): read.
  auto all_texcoord1 = [](nlohmann::json& d) {
    for (const char* field : {"normalTexture", "occlusionTexture"}) d["materials"][0][field]["texCoord"] = 1;
    for (const char* field : {"baseColorTexture", "metallicRoughnessTexture"})
      d["materials"][0]["pbrMetallicRoughness"][field]["texCoord"] = 1;
  };
  const std::string e = load_error(with_json(glb, all_texcoord1));
  EXPECT_NE(e.find("material 0: has textures, but a primitive of mesh 0 that uses it has no TEXCOORD_1"),
            std::string::npos) << e;
  const GltfModel second = load_gltf_model(with_json(glb, [&](nlohmann::json& d) {
    all_texcoord1(d);
    for (nlohmann::json& prim : d["meshes"][0]["primitives"])
      prim["attributes"]["TEXCOORD_1"] = prim["attributes"]["TEXCOORD_0"];
  }), "second.glb");
  EXPECT_EQ(std::vector<glm::vec2>(second.mesh.uvs.begin(), second.mesh.uvs.begin() + std::ptrdiff_t(n)),
            made.mesh.uvs);
}

}  // namespace
}  // namespace arlight::render
