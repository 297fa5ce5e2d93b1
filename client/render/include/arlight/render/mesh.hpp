// Triangle meshes for the renderer: positions, normals, optional uvs and tangents, uint32
// indices, parts, bounds. Loaded from glTF 2.0 (gltf.hpp) or generated (a UV sphere).
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <glm/mat4x4.hpp>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>
#include <glm/vec4.hpp>
#include <span>
#include <string>
#include <vector>

namespace arlight::render {

struct Bounds {
  glm::vec3 min{0.0f}, max{0.0f};
  glm::vec3 centre() const { return 0.5f * (min + max); }
  glm::vec3 size() const { return max - min; }
};

// The mesh's occlusion of the floor it stands on (tutorial §6.1's receiver plane), baked: over a
// rectangle [min, max] of x and z (object frame) on the plane y = bounds.min.y, size x size texels
// (row-major, rows along z) of the cosine-weighted share of the sky the mesh hides from an
// up-facing floor point (1 - its ambient occlusion). Empty: not baked.
inline constexpr int kTransferCoefficients = 9;  // SH-9 transfers (order 3, bands 0-2)
struct GroundOcclusion {
  glm::vec2 min{0.0f}, max{0.0f};
  int size = 0;
  std::vector<float> occluded;
  // Empty or kTransferCoefficients per texel: the SH-9 transfer of the light the mesh hides from
  // the floor point (the open cosine lobe's transfer minus the occluded one's; object frame), so
  // the share hidden follows where the room's light comes from (tutorial §6.1).
  std::vector<float> hidden_transfer;
  bool empty() const { return size == 0; }
};

// A run of a mesh's triangles drawn with one material: indices [first_index, first_index +
// index_count) of Mesh::indices, and the index of its material in the list that came with the
// mesh (GltfModel::materials), or -1 for none (the caller's material).
struct MeshPart {
  std::uint32_t first_index = 0, index_count = 0;
  int material = -1;
};

// uv (0,0) is the top-left of a texture image (as in glTF and image files). Tangents follow
// glTF / MikkTSpace: xyz along increasing u, w = +-1 with bitangent = w * cross(normal, tangent)
// pointing *up* the image (decreasing v), so normal maps are in the OpenGL (+Y up) convention.
struct Mesh {
  std::vector<glm::vec3> positions;
  std::vector<glm::vec3> normals;      // unit, one per position
  std::vector<glm::vec2> uvs;          // empty or one per position
  std::vector<glm::vec4> tangents;     // empty or one per position (computed when uvs exist)
  // Empty or one per position: the mesh's occlusion of itself, baked (transfer.hpp): the bent
  // normal (xyz, object frame) and the ambient occlusion (w). The diffuse light is looked up
  // along the bent normal and scaled by the occlusion, so creases darken as the room's light says.
  std::vector<glm::vec4> occlusion;
  // Empty or kTransferCoefficients per position: each vertex's SH-9 radiance transfer with the
  // mesh's occlusion of itself (transfer.hpp's Transfer::sh, object frame). The renderer dots it
  // with the room's SH, so a crease darkens by how much of the light its open side lets in,
  // not by a uniform share (tutorial §6.1).
  std::vector<float> transfer;
  GroundOcclusion ground;
  std::vector<std::uint32_t> indices;  // triangles
  // Empty (the whole mesh, one material) or the runs of indices in order, one per glTF
  // primitive, covering every index.
  std::vector<MeshPart> parts;
  Bounds bounds;

  std::size_t vertex_count() const { return positions.size(); }
  std::size_t triangle_count() const { return indices.size() / 3; }
};

// Recomputes bounds from the positions.
void compute_bounds(Mesh& mesh);
// Per-vertex tangents from the uvs: each triangle's dP/du and dP/dv are accumulated (weighted
// by the triangle's uv-space area, MikkTSpace-style), orthogonalised against the normal
// (Gram-Schmidt), with w the handedness. Needs uvs; a degenerate vertex gets any perpendicular.
void compute_tangents(Mesh& mesh);
// Area-weighted vertex normals from the triangles (for meshes that come without normals).
void compute_normals(Mesh& mesh);

// A UV sphere centred at the origin, poles on +-Y: `rings` bands from the north pole (v = 0) to
// the south pole (v = 1), `segments` around. u = 0.25 faces +Z, u grows towards +X there, so the
// tangent at the front (0, 0, r) is +X and the bitangent +Y. The seam at u = 0/1 faces -X.
Mesh make_sphere(float radius, int rings, int segments);

// Bakes the mesh's occlusion of itself into mesh.occlusion (bent normals and ambient occlusion
// of its vertices, arlight::bake_transfer with Embree on all cores; `directions` rays per
// vertex over the sphere), and of the floor it stands on into mesh.ground (a 64 x 64 grid
// reaching 3 half-extents from its centre, as far as the shadow catcher's contact shadow).
// Native only: the browser build has no Embree.
void bake_occlusion(Mesh& mesh, int directions = 1024);

// Thesis Alg. 5.2's light map, baked instead of read from a file: per texel of a width x height
// map over the mesh's UVs, the ambient occlusion of the surface point there (its position and
// normal interpolated from the triangle's corners): width x height values, row 0 at v = 0 (the
// top of the image, as TextureImage stores it). Texels no
// triangle covers take their covered neighbours' mean (a few texels of padding, so bilinear
// filtering and mipmaps do not bleed white into the seams), and 1 beyond. Needs UVs
// (std::invalid_argument without). Native only, as bake_occlusion.
std::vector<float> bake_light_map(const Mesh& mesh, int width, int height, int directions = 1024);

// Visits every texel of a width x height texture whose centre lies inside one of the mesh's
// UV triangles (either winding; texel (i, j) has its centre at uv ((i + .5) / width,
// (j + .5) / height), wrapped into the texture as GL_REPEAT does), with the triangle (the
// position of its first index in mesh.indices) and the centre's barycentric coordinates. A
// triangle thinner than a texel that holds no centre visits the texels its corners are in (the
// coordinates of that corner). Degenerate and wildly repeating triangles are skipped.
void for_each_uv_texel(const Mesh& mesh, int width, int height,
                       const std::function<void(int x, int y, std::size_t triangle,
                                                const glm::dvec3& barycentric)>& visit);

// The model matrix that stands a +Y-up model (glTF's convention) on a tracked marker, whose
// frame has +Z out of the floor (OpenCV aruco): rotated +Y -> +Z, scaled to `height` metres,
// the bottom of its bounds on the marker plane, centred on the marker.
glm::mat4 standing_on_marker(const Bounds& bounds, float height);

}  // namespace arlight::render
