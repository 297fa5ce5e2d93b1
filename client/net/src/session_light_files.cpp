#include "arlight/net/session_light_files.hpp"

#include "arlight/common/error.hpp"
#include "arlight/common/light_files.hpp"
#include "arlight/common/light_sources.hpp"

namespace arlight::client {

void write_session_light_files(const std::filesystem::path& dir, const ReceivedMapSet& chain,
                               const ShCoeffs& sh, const std::string& source) {
  if (chain.kind != wire::MapKind::Ggx || chain.maps.empty())
    throw InputError("light files: the session sent no GGX chain");
  if (sh.order < 3)
    throw InputError("light files: the session's SH has order " + std::to_string(sh.order) +
                     ", below the 3 of SH-9");
  LightFilesInput light;
  light.sh = sh;
  // The chain's level 0 is the room itself (the mirror), at the chain's face.
  light.primary = primary_light(chain.maps.front(), sh);
  light.specular = chain.maps;
  light.roughness = chain.roughness;
  light.source = source;
  write_light_files(dir, light);
}

}  // namespace arlight::client
