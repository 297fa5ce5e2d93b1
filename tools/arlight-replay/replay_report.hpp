// What arlight-replay writes once a recording is streamed: OUT/replay.json (and --json) with
// the session, the counts, the last live SH, the dominant light and the sun, and the last
// complete map set as OUT/maps/s<S>.exr, or with a GGX chain its light files (OUT/specular.ktx2,
// light.json, lighting.gltf).
#pragma once

#include <cstddef>
#include <filesystem>
#include <string>

#include "arlight/net/client_net.hpp"

namespace arlight::replay_tool {

void write_replay_results(const std::filesystem::path& out, const std::string& json_path,
                          const client::Welcome& w, const client::Client& c, std::size_t sent);

}  // namespace arlight::replay_tool
