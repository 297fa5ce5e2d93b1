// Fuzz target: a model file as the clients and arlight-model load it, with its materials (glTF 2.0
// binary or JSON with data: URIs, through tinygltf; Draco-compressed primitives through libdraco;
// PNG / JPEG textures through stb_image). Every problem must be an InputError; a mesh that loads
// has indices inside its vertices, one normal per position, parts within its indices and
// materials for the parts that name one, and textures whose texels are all there.
#include "arlight/common/error.hpp"
#include "arlight/render/gltf.hpp"
#include "fuzz_support.hpp"

using namespace arlight;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  try {
    const render::GltfModel model = render::load_gltf_model({data, size}, "fuzz.glb");
    const render::Mesh& mesh = model.mesh;
    for (std::uint32_t i : mesh.indices)
      if (i >= mesh.positions.size()) fuzz::finding("a loaded mesh indexes past its vertices");
    if (mesh.normals.size() != mesh.positions.size())
      fuzz::finding("a loaded mesh has not one normal per position");
    for (const render::MeshPart& part : mesh.parts)
      if (std::size_t(part.first_index) + part.index_count > mesh.indices.size() ||
          part.material >= int(model.materials.size()))
        fuzz::finding("a part beyond the indices or naming a material that is not there");
    for (const render::Material& m : model.materials)
      for (const auto* t : {m.albedo.get(), m.normal_map.get(), m.pbr->metallic_roughness.get(),
                            m.pbr->occlusion.get(), m.pbr->emissive_map.get()})
        if (t && t->u8.size() != std::size_t(t->width) * std::size_t(t->height) * std::size_t(t->channels))
          fuzz::finding("a texture without all its texels");
  } catch (const InputError& e) {
    fuzz::refused(e);
  }
  return 0;
}

FuzzSeeds arlight_fuzz_seeds() {
  render::Mesh quad;
  quad.positions = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  quad.normals.assign(4, {0, 0, 1});
  quad.uvs = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
  quad.indices = {0, 1, 2, 0, 2, 3};
  render::Mesh bare = quad;
  bare.uvs.clear();
  // The bundled bunny: Draco-compressed (data/models/README.md).
  const std::string bunny =
      fuzz::read_file(std::filesystem::path(ARLIGHT_SOURCE_DIR) / "data" / "models" / "bunny.glb");
  // A quad with a textured metallic-roughness material (4 x 4 PNGs) and one without textures.
  render::Mesh parted = quad;
  parted.parts = {{0, 3, 0}, {3, 3, 1}};
  render::Material textured, plain;
  textured.pbr = render::MetallicRoughness{}, plain.pbr = render::MetallicRoughness{};
  const std::uint8_t texels[4 * 4 * 3] = {255, 0, 0, 0, 255, 0, 0, 0, 255, 128, 128, 128};
  const ImageU8View image{texels, 4, 4, 3, 12};
  textured.albedo = render::make_texture(image, true);
  textured.pbr->metallic_roughness = render::make_texture(image, false);
  textured.pbr->alpha_mask = true;
  plain.pbr->alpha_blend = true;
  const std::vector<render::Material> materials = {textured, plain};
  return {render::encode_glb(quad), render::encode_glb(bare), fuzz::bytes_of(bunny),
          render::encode_glb(parted, materials)};
}
