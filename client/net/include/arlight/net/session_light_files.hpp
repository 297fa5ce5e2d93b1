// What a session streamed, as the light files engines read (common/light_files.hpp): its GGX
// chain, the live SH of its newest LightingUpdate, and the primary light of the chain's mirror
// level (the room itself: common/light_sources.hpp). The native tools'
// --out (arlight-replay); the page does not write files.
#pragma once

#include <filesystem>
#include <string>

#include "arlight/net/map_assembly.hpp"
#include "arlight/protocol/wire.hpp"

namespace arlight::client {

// Writes dir/specular.ktx2, dir/light.json and dir/lighting.gltf (with its images). Throws
// InputError when `chain` is not a GGX chain or `sh` (the live radiance SH) is below order 3.
void write_session_light_files(const std::filesystem::path& dir, const ReceivedMapSet& chain,
                               const ShCoeffs& sh, const std::string& source);

}  // namespace arlight::client
