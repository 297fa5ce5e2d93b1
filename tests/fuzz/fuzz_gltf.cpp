// Fuzz target: a model file as the client and arlight-model load it (glTF 2.0 binary or JSON with
// data: URIs; Draco-compressed primitives through libdraco). Every problem must be an
// InputError; a mesh that loads has indices inside its vertices and one normal per position.
#include "arlight/common/error.hpp"
#include "arlight/render/gltf.hpp"
#include "fuzz_support.hpp"

using namespace arlight;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  try {
    const render::Mesh mesh = render::load_gltf({data, size}, "fuzz.glb");
    for (std::uint32_t i : mesh.indices)
      if (i >= mesh.positions.size()) fuzz::finding("a loaded mesh indexes past its vertices");
    if (mesh.normals.size() != mesh.positions.size())
      fuzz::finding("a loaded mesh has not one normal per position");
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
  return {render::encode_glb(quad), render::encode_glb(bare), fuzz::bytes_of(bunny)};
}
