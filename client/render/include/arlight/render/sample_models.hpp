// Models the project makes itself, for its tests, benchmarks and demo (CC0, like the bundled
// ones): a textured glTF metallic-roughness model to check every texture path of the shading.
#pragma once

#include "arlight/render/gltf.hpp"

namespace arlight::render {

// A tiled ball on a plinth, +Y up, 1 unit tall: the ball (material 0, "tiles") is a UV sphere
// tiled 8 around x 6 down in gold (metal, roughness 0.15-0.45 by row) and terracotta (dielectric,
// roughness 0.6), with grooves between the tiles: a base colour texture (sRGB), metal/roughness
// (B/G), a tangent-space normal map (the grooves' bevels) and an occlusion texture (the
// grooves), all texture_size x texture_size; the plinth (material 1, "glaze") is a glazed white
// of factors only. Two primitives, two materials: what encode_glb writes is a file any glTF
// viewer shows the same way.
GltfModel make_tiled_ball(int texture_size = 256);

}  // namespace arlight::render
