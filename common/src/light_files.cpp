// The light files (see light_files.hpp): conventions and layouts of the engines that read them.
#include "arlight/common/light_files.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <glm/geometric.hpp>
#include <glm/gtc/quaternion.hpp>
#include <cmath>
#include <numbers>
#include <stdexcept>

#include "arlight/common/atomic_file.hpp"
#include "arlight/common/hdr_io.hpp"
#include "arlight/common/ktx2.hpp"

namespace arlight {

namespace {

constexpr double kPi = std::numbers::pi;
// Band of each of the 9 coefficients, and the basis constants of the polynomials Filament's and
// three.js's shaders evaluate (1, y, z, x, xy, yz, 3z^2 - 1, xz, x^2 - y^2).
constexpr int kBand[9] = {0, 1, 1, 1, 2, 2, 2, 2, 2};
constexpr double kBasis[9] = {0.282094791773878, 0.488602511902920, 0.488602511902920,
                              0.488602511902920, 1.092548430592079, 1.092548430592079,
                              0.315391565252520, 1.092548430592079, 0.546274215296040};
// The clamped cosine's zonal factors A_l (Ramamoorthi & Hanrahan 2001).
constexpr double kCosineLobe[3] = {kPi, 2.0 * kPi / 3.0, kPi / 4.0};

}  // namespace

std::array<float, 27> sh9_filament(const ShCoeffs& sh) {
  std::array<float, 27> out = sh9_webxr(sh);
  for (int i = 0; i < 9; ++i)
    for (int c = 0; c < 3; ++c)
      out[std::size_t(3 * i + c)] *= float(kBasis[i] * kCosineLobe[kBand[i]] / kPi);
  return out;
}

std::array<float, 27> sh9_unity(const ShCoeffs& sh) {
  // Mirroring z flips the basis functions odd in z: Y_1,0 (z), Y_2,-1 (yz), Y_2,1 (xz).
  std::array<float, 27> raw = sh9_webxr(sh);
  std::array<float, 27> out{};
  for (int i = 0; i < 9; ++i)
    for (int c = 0; c < 3; ++c) {
      const float sign = (i == 2 || i == 5 || i == 7) ? -1.0f : 1.0f;
      out[std::size_t(9 * c + i)] = sign * raw[std::size_t(3 * i + c)];
    }
  return out;
}

std::string light_json(const LightFilesInput& light) {
  using nlohmann::json;
  const auto webxr = sh9_webxr(light.sh), filament = sh9_filament(light.sh), unity = sh9_unity(light.sh);
  json levels = json::array();
  for (std::size_t k = 0; k < light.specular.size(); ++k)
    levels.push_back({{"level", k},
                      {"face", light.specular[k].layout.face_size()},
                      {"roughness", k < light.roughness.size() ? light.roughness[k] : 0.0}});
  const glm::vec3 d = light.primary.direction, i = light.primary.colour;
  json j = {
      {"format", "arlight light 1"},
      {"source", light.source},
      {"frame",
       {{"handedness", "right"},
        {"up", "+Y"},
        {"forward", "-Z"},
        {"directions", "unit vectors from the probe towards where light comes from"},
        {"units", "linear relative radiance (the capture's scale)"}}},
      {"sh9",
       {{"order", "(l,m) = (0,0) (1,-1) (1,0) (1,1) (2,-2) (2,-1) (2,0) (2,1) (2,2); RGB interleaved"},
        {"webxr", std::vector<float>(webxr.begin(), webxr.end())},
        {"webxr_convention",
         "raw radiance coefficients, real orthonormal basis without Condon-Shortley phase "
         "(Y1-1 ~ y, Y10 ~ z, Y11 ~ x), as XRLightProbe.sphericalHarmonicsCoefficients and "
         "three.js LightProbe.sh.fromArray take them"},
        {"filament", std::vector<float>(filament.begin(), filament.end())},
        {"filament_convention",
         "pre-scaled for IndirectLight::Builder::irradiance(3, sh) like cmgen --sh-shader: "
         "times the basis constant and A_l / pi (irradiance / pi from Filament's polynomial)"},
        {"unity", {{"r", std::vector<float>(unity.begin(), unity.begin() + 9)},
                   {"g", std::vector<float>(unity.begin() + 9, unity.begin() + 18)},
                   {"b", std::vector<float>(unity.begin() + 18, unity.end())}}},
        {"unity_convention",
         "SphericalHarmonicsL2[channel, i]: raw radiance coefficients in Unity's left-handed "
         "frame (+Z forward, z mirrored: coefficients 2, 5, 7 negated)"}}},
      {"primary_light",
       {{"direction", {d.x, d.y, d.z}},
        {"intensity", {i.x, i.y, i.z}},
        {"from", "the light tree's brightest clusters (tutorial 6.2's median cut over the room's brightest texels, "
                 "for a receiver facing the SH's dominant direction): their mean direction and "
                 "illuminance at normal incidence"}}},
      {"specular",
       {{"file", "specular.ktx2"},
        {"format", "KTX 2.0 cube, VK_FORMAT_R16G16B16A16_SFLOAT, linear"},
        {"prefilter", "GGX, n = v = R, sum L D (R.l)+ / sum D (R.l)+ (the split sum's)"},
        {"face_order", "+X -X +Y -Y +Z -Z (Vulkan/OpenGL cube table, row 0 at the top)"},
        {"level_mapping", kGgxLevelMapping},
        {"levels", levels}}},
      {"gltf", {{"file", "lighting.gltf"},
                {"extension", light.lights.empty() ? json("EXT_lights_image_based")
                                                   : json({"EXT_lights_image_based", "KHR_lights_punctual"})}}},
  };
  if (!light.lights.empty()) {
    json lights = json::array();
    for (const SpecularLight& l : light.lights)
      lights.push_back({{"direction", {l.direction.x, l.direction.y, l.direction.z}},
                        {"intensity", {l.power.x, l.power.y, l.power.z}},
                        {"angular_radius", l.radius}});
    j["lights"] = {
        {"holds", "the room's small, bright lights, taken out of sh9 and specular (which hold "
                  "the rest): add each as a directional light, for diffuse and specular alike"},
        {"from", "every texel above 128 x the room's mean luminance gives its excess over the "
                 "mean; compact clusters of those texels (arlight split_specular_lights)"},
        {"intensity", "illuminance at normal incidence (RGB): sum of excess radiance x solid angle"},
        {"angular_radius", "radians: the disc a renderer may widen a highlight to"},
        {"directional", lights}};
    j["sh9"]["holds"] = "the room less lights.directional";
    j["specular"]["holds"] = "the room less lights.directional";
  }
  return j.dump(2) + "\n";
}

std::vector<std::uint8_t> specular_ktx2(const LightFilesInput& light) {
  const nlohmann::json meta = {{"level_mapping", kGgxLevelMapping}, {"roughness", light.roughness}};
  return encode_ktx2_cube(light.specular, {{"arlight.ggx", meta.dump()}});
}

void write_specular_ktx2(const std::filesystem::path& path, const LightFilesInput& light) {
  const auto bytes = specular_ktx2(light);
  write_file_atomically(path, std::string_view(reinterpret_cast<const char*>(bytes.data()), bytes.size()));
}

namespace {

// EXT_lights_image_based's RGBD (as Babylon.js packs it): rgb = (L D)^(1/2.2), a = D with
// D = floor(min(255 / max(L), 255)) / 255, so L = rgb^2.2 / a.
std::vector<std::uint8_t> rgbd_face(const EnvMap& map, int face) {
  const int n = map.layout.face_size();
  std::vector<std::uint8_t> out(std::size_t(n) * std::size_t(n) * 4);
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) {
      // "Each saved image must be flipped about its vertical axis" (the extension's text).
      const glm::vec3 l = glm::max(map.image.at(n - 1 - x, face * n + y), glm::vec3(0.0f));
      const float peak = std::max({l.x, l.y, l.z, 1e-6f});
      const float dv = std::floor(std::clamp(255.0f / peak, 1.0f, 255.0f)) / 255.0f;
      std::uint8_t* px = &out[4 * (std::size_t(y) * std::size_t(n) + std::size_t(x))];
      for (int c = 0; c < 3; ++c)
        px[c] = std::uint8_t(std::lround(255.0f * std::clamp(std::pow(l[c] * dv, 1.0f / 2.2f), 0.0f, 1.0f)));
      px[3] = std::uint8_t(std::lround(255.0f * dv));
    }
  return out;
}

}  // namespace

void write_light_files(const std::filesystem::path& dir, const LightFilesInput& light) {
  using nlohmann::json;
  if (light.specular.empty()) throw std::invalid_argument("light files: no specular chain");
  std::filesystem::create_directories(dir / "lighting");
  write_specular_ktx2(dir / "specular.ktx2", light);
  write_file_atomically(dir / "light.json", light_json(light));

  // glTF: the face images, and Babylon's irradiance SH (irradiance = A_l c_lm, with the
  // Condon-Shortley phase Babylon's basis carries: odd m negated).
  json images = json::array(), specular = json::array();
  for (std::size_t k = 0; k < light.specular.size(); ++k) {
    json faces = json::array();
    for (int f = 0; f < 6; ++f) {
      const std::string name = "lighting/m" + std::to_string(k) + "_" + std::to_string(f) + ".png";
      const int n = light.specular[k].layout.face_size();
      write_png_rgba(dir / name, n, n, rgbd_face(light.specular[k], f));
      faces.push_back(images.size());
      images.push_back({{"uri", name}, {"mimeType", "image/png"}});
    }
    specular.push_back(faces);
  }
  const auto webxr = sh9_webxr(light.sh);
  json irradiance = json::array();
  for (int i = 0; i < 9; ++i) {
    const double sign = (i == 1 || i == 3 || i == 5 || i == 7) ? -1.0 : 1.0;
    json rgb = json::array();
    for (int c = 0; c < 3; ++c) rgb.push_back(sign * kCosineLobe[kBand[i]] * webxr[std::size_t(3 * i + c)]);
    irradiance.push_back(rgb);
  }
  json gltf = {
      {"asset", {{"version", "2.0"}, {"generator", "arlight"}}},
      {"extensionsUsed", {"EXT_lights_image_based"}},
      {"extensions",
       {{"EXT_lights_image_based",
         {{"lights",
           {{{"name", "arlight room"},
             {"intensity", 1.0},
             {"rotation", {0.0, 0.0, 0.0, 1.0}},
             {"irradianceCoefficients", irradiance},
             {"specularImageSize", light.specular[0].layout.face_size()},
             {"specularImages", specular}}}}}}}},
      {"images", images},
      {"scene", 0},
      {"scenes", {{{"name", "arlight light"}, {"extensions", {{"EXT_lights_image_based", {{"light", 0}}}}}}}},
  };
  if (!light.lights.empty()) {
    // KHR_lights_punctual: a directional light shines along its node's -Z, so the node's +Z is
    // the direction towards the light. Colour the normalised RGB, intensity its largest channel.
    json lights = json::array(), nodes = json::array(), scene_nodes = json::array();
    for (std::size_t i = 0; i < light.lights.size(); ++i) {
      const SpecularLight& l = light.lights[i];
      const float peak = std::max({l.power.x, l.power.y, l.power.z, 1e-30f});
      lights.push_back({{"name", "arlight light " + std::to_string(i)},
                        {"type", "directional"},
                        {"color", {l.power.x / peak, l.power.y / peak, l.power.z / peak}},
                        {"intensity", peak}});
      // The rotation taking +Z to the light's direction, as glTF writes it: (x, y, z, w).
      const glm::dquat q(glm::dvec3(0, 0, 1), glm::normalize(glm::dvec3(l.direction)));
      scene_nodes.push_back(nodes.size());
      nodes.push_back({{"name", "arlight light " + std::to_string(i)},
                       {"rotation", {q.x, q.y, q.z, q.w}},
                       {"extensions", {{"KHR_lights_punctual", {{"light", i}}}}}});
    }
    gltf["extensionsUsed"].push_back("KHR_lights_punctual");
    gltf["extensions"]["KHR_lights_punctual"] = {{"lights", lights}};
    gltf["nodes"] = nodes;
    gltf["scenes"][0]["nodes"] = scene_nodes;
  }
  write_file_atomically(dir / "lighting.gltf", gltf.dump(2) + "\n");
}

}  // namespace arlight
