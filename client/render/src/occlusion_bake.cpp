// The mesh's occlusion of itself, baked with Embree (mesh.hpp, transfer.hpp).
#include "arlight/render/mesh.hpp"
#include "arlight/transfer.hpp"

namespace arlight::render {

void bake_occlusion(Mesh& mesh, int directions) {
  const Occluder occluder(mesh.positions, mesh.indices);
  // Order 1: the bent normal and the occlusion are all the renderer reads.
  const Transfer t =
      bake_transfer(occluder, mesh.positions, mesh.normals, {.directions = directions, .order = 1});
  mesh.occlusion.resize(t.size());
  for (std::size_t i = 0; i < t.size(); ++i)
    mesh.occlusion[i] = glm::vec4(t.bent_normal[i], t.ao[i]);
}

}  // namespace arlight::render
