// KTX 2.0 cube maps with a mip chain (Khronos KTX 2.0 specification): what engines load a
// prefiltered environment from (three.js KTX2Loader, Filament, Babylon.js, Cesium).
//
// Written: VK_FORMAT_R16G16B16A16_SFLOAT (97), linear BT.709 primaries, alpha 1, no
// supercompression, faces in the order +X, -X, +Y, -Y, +Z, -Z with the texel orientation of
// common/CONVENTIONS.md (the GL/Vulkan cube table, row 0 at the top), levels halving the face.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "arlight/common/projection.hpp"

namespace arlight {

inline constexpr std::uint32_t kVkFormatR16G16B16A16Sfloat = 97;

using Ktx2KeyValues = std::vector<std::pair<std::string, std::string>>;

// The file's bytes for a cube-map chain: levels[k] must be a cube map of face levels[0]'s >> k.
// Key/value entries are written sorted by key (as the format requires), with KTXwriter added.
// Throws std::invalid_argument for levels that do not form a chain.
std::vector<std::uint8_t> encode_ktx2_cube(std::span<const EnvMap> levels,
                                           const Ktx2KeyValues& key_values = {});

struct Ktx2Cube {
  std::vector<EnvMap> levels;
  Ktx2KeyValues key_values;
};
// Reads a file encode_ktx2_cube's layout describes (RGBA16F or RGBA32F cube, uncompressed),
// checking every offset and length. Throws InputError naming what is wrong.
Ktx2Cube decode_ktx2_cube(std::span<const std::uint8_t> bytes);

}  // namespace arlight
