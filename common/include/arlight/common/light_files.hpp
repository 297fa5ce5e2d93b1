// A room's light in the files the field's engines read (issue 34 §4): the GGX chain as KTX2,
// SH-9 in WebXR's / three.js's, Filament's and Unity's shapes with the primary light as JSON,
// and a glTF with EXT_lights_image_based as Babylon.js reads it.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <span>
#include <string>
#include <vector>

#include "arlight/common/projection.hpp"
#include "arlight/common/sh.hpp"
#include "arlight/common/specular_lights.hpp"

namespace arlight {

// The GGX chain's level <-> roughness mapping, Filament's (cmgen, IBLPrefilterContext,
// perceptualRoughnessToLod's inverse): r = 1 - sqrt(1 - level / (levels - 1)), level 0 the
// mirror (r = 0). The server computes chains at it, the renderer samples them by its inverse,
// and every file that holds a chain states it.
inline double ggx_level_roughness(int level, int levels) {
  if (levels < 2 || level <= 0) return 0.0;
  const double lod = std::clamp(double(level) / double(levels - 1), 0.0, 1.0);
  return 1.0 - std::sqrt(1.0 - lod);
}
// Its inverse: the (fractional) level an engine samples for roughness r.
inline double ggx_roughness_level(double roughness, int levels) {
  const double r = std::clamp(roughness, 0.0, 1.0);
  return (1.0 - (1.0 - r) * (1.0 - r)) * double(std::max(levels - 1, 0));
}
inline constexpr const char* kGgxLevelMapping =
    "roughness = 1 - sqrt(1 - level / (levels - 1)) (Filament's perceptualRoughnessToLod "
    "inverse); alpha = roughness^2; level 0 is the mirror";

struct LightFilesInput {
  ShCoeffs sh;                      // radiance SH of the room, order >= 3 (bands above 2 unused)
  DominantLight primary;  // light_sources.hpp's primary_light(): towards it (unit), RGB illuminance
  std::span<const EnvMap> specular;  // the GGX chain (cube maps, level 0 the mirror)
  std::vector<double> roughness;    // per level
  std::string source;               // what the light was measured from, for the record
  // The room's small, bright lights taken out of it (split_specular_lights, issue 51 §1): `sh`
  // and `specular` then hold the rest (the residual), and light.json and lighting.gltf carry
  // these as directional lights (KHR_lights_punctual) that an engine adds for diffuse and
  // specular. Empty: `sh` and `specular` are the whole room.
  std::vector<SpecularLight> lights;
};

// SH-9 as 27 floats, 9 RGB triples in the order (l, m) = (0,0), (1,-1), (1,0), (1,1), (2,-2),
// (2,-1), (2,0), (2,1), (2,2), in the world frame of common/CONVENTIONS.md (right-handed, +Y up,
// -Z forward; glTF's, three.js's and Filament's too):
// - webxr: sh.hpp's sh9_webxr() — raw radiance coefficients, as WebXR's
//   sphericalHarmonicsCoefficients and three.js's LightProbe.sh.fromArray take them;
// - filament: pre-scaled for IndirectLight::Builder::irradiance(3, ...) (cmgen --sh-shader):
//   each coefficient times its band's cosine-lobe factor A_l / pi and the basis constant, so
//   Filament's shader polynomial gives irradiance / pi;
// - unity: raw radiance coefficients in Unity's left-handed frame (+Z forward: z mirrored),
//   as SphericalHarmonicsL2[channel, i] holds them (written per channel).
std::array<float, 27> sh9_filament(const ShCoeffs& sh);
std::array<float, 27> sh9_unity(const ShCoeffs& sh);

// light.json's text.
std::string light_json(const LightFilesInput& light);
// specular.ktx2's bytes: the chain with its level mapping and roughness in the key
// "arlight.ggx" (JSON, with kGgxLevelMapping). Needs only `specular` and `roughness`.
std::vector<std::uint8_t> specular_ktx2(const LightFilesInput& light);
// The same written to `path` atomically (a reader never sees half a file).
void write_specular_ktx2(const std::filesystem::path& path, const LightFilesInput& light);

// Writes dir/specular.ktx2, dir/light.json, dir/lighting.gltf and the glTF's face images
// (dir/lighting/m<L>_<face>.png, RGBD as EXT_lights_image_based defines it). Creates dir.
void write_light_files(const std::filesystem::path& dir, const LightFilesInput& light);

}  // namespace arlight
