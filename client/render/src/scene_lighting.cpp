#include "scene_lighting.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>

#include "arlight/common/light_files.hpp"
#include "textures.hpp"

namespace arlight::render {

namespace {

constexpr int kShMapSize = 32;                             // SH maps: 64 x 32 lat-long
const std::vector<double> kShShininess = {1, 8, 32, 128};  // SH maps' lobes
constexpr int kHorizontalNormals = 16;                     // HemispherePriors' light and shadow

}  // namespace

void EnvSet::upload(const std::vector<double>& s, const std::vector<EnvMap>& maps) {
  std::vector<std::size_t> order(s.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::sort(order.begin(), order.end(), [&](auto a, auto b) { return s[a] < s[b]; });
  if (tex.size() != maps.size() || projection != maps[0].layout.projection()) {
    tex.clear(), size.clear();
    tex.resize(maps.size()), size.resize(maps.size(), glm::ivec2(0));
  }
  projection = maps[0].layout.projection();
  shininess.clear();
  for (std::size_t k = 0; k < order.size(); ++k) {
    shininess.push_back(s[order[k]]);
    upload_env(maps[order[k]], tex[k], size[k].x, size[k].y);
  }
}

std::tuple<std::size_t, std::size_t, float> EnvSet::pick(double s, ReflectionLookup lookup) const {
  const std::size_t n = shininess.size();
  if (s <= shininess.front()) return {0, 0, 0.0f};
  if (s >= shininess.back()) return {n - 1, n - 1, 0.0f};
  std::size_t i = 0;
  while (i + 1 < n && shininess[i + 1] <= s) ++i;
  if (shininess[i] == s) return {i, i, 0.0f};
  const double t = (std::log(s) - std::log(shininess[i])) /
                   (std::log(shininess[i + 1]) - std::log(shininess[i]));
  if (lookup == ReflectionLookup::Nearest)
    return t < 0.5 ? std::tuple{i, i, 0.0f} : std::tuple{i + 1, i + 1, 0.0f};
  return {i, i + 1, float(t)};
}

void SceneLighting::set_ggx_chain(const std::vector<EnvMap>& levels,
                                  const std::vector<double>& roughness,
                                  const std::vector<SpecularLight>& lights) {
  if (lights.size() > std::size_t(kMaxSpecularLights))
    throw std::invalid_argument("GGX chain: " + std::to_string(lights.size()) + " lights (at most " +
                                std::to_string(kMaxSpecularLights) + ")");
  for (const SpecularLight& l : lights)
    if (const char* problem = specular_light_problem(l))
      throw std::invalid_argument(std::string("GGX chain: a light cannot be shaded: ") + problem);
  if (levels.empty() || levels.size() != roughness.size())
    throw std::invalid_argument("GGX chain: " + std::to_string(levels.size()) + " levels and " +
                                std::to_string(roughness.size()) + " roughness values");
  if (levels.size() > 16) throw std::invalid_argument("GGX chain: more than 16 levels");
  const int n = int(levels.size());
  for (int k = 0; k < n; ++k) {
    const EnvLayout& l = levels[std::size_t(k)].layout;
    if (l.projection() != Projection::Cube || l.face_size() != levels[0].layout.face_size() >> k ||
        l.face_size() < 1)
      throw std::invalid_argument("GGX chain: level " + std::to_string(k) +
                                  " is not a cube map of half the face of the level before");
    // The shader samples level (n - 1) r (2 - r), Filament's mapping: the chain must follow it.
    if (!(std::abs(ggx_roughness_level(roughness[std::size_t(k)], n) - k) < 1e-3))
      throw std::invalid_argument("GGX chain: level " + std::to_string(k) + "'s roughness " +
                                  std::to_string(roughness[std::size_t(k)]) +
                                  " does not follow Filament's level mapping");
  }
  ggx_ = upload_ggx_chain(levels);
  ggx_levels_ = n;
  ggx_lights_ = lights;
}

SceneLighting::SceneLighting() {
  EnvMap zero(EnvLayout::for_size(Projection::LatLong, 1));
  black_.upload({1.0}, {zero});
}

void SceneLighting::set_room_sh(const ShCoeffs& sh) {
  room_sh_ = ShCoeffs(3);
  for (int k = 0; k < std::min(sh_count(3), int(sh.c.size())); ++k)
    room_sh_.c[std::size_t(k)] = sh.c[std::size_t(k)];
}

void SceneLighting::set_sh(const ShCoeffs& sh) {
  if (sh.order < 1 || sh.c.size() != std::size_t(sh_count(sh.order)))
    throw std::invalid_argument("set_sh: coefficients do not match their order");
  if (sh.order == last_sh_.order && sh.c == last_sh_.c) return;
  last_sh_ = sh;
  if (maps_.empty()) set_room_sh(sh);
  irradiance_sh_ = sh_convolve(sh, phong_zonal_all(sh.order, 1.0));
  const EnvLayout layout = EnvLayout::for_size(Projection::LatLong, kShMapSize);
  std::vector<EnvMap> maps;
  for (double s : kShShininess) {
    // Thesis eq. 2.33: band l times Lambda_l rho_l of the normalized Phong lobe (s = 1: the
    // clamped cosine, i.e. irradiance / pi, the irradiance map's value).
    Image img = sh_reconstruct(sh_convolve(sh, phong_zonal_all(sh.order, s)), layout);
    for (float& v : img.storage()) v = std::max(v, 0.0f);  // truncation ringing
    maps.emplace_back(layout, std::move(img));
  }
  sh_maps_.upload(kShShininess, maps);
  sh_priors_.reset();
}

void SceneLighting::set_maps(const std::vector<double>& shininess,
                             const std::vector<EnvMap>& maps) {
  if (maps.empty() || maps.size() != shininess.size())
    throw std::invalid_argument("set_maps: need one map per shininess, at least one");
  for (std::size_t i = 0; i < maps.size(); ++i) {
    if (maps[i].layout.projection() != maps[0].layout.projection())
      throw std::invalid_argument("set_maps: all maps must have one projection");
    if (!(shininess[i] > 0.0)) throw std::invalid_argument("set_maps: shininess must be positive");
  }
  maps_.upload(shininess, maps);
  const std::size_t smallest =
      std::size_t(std::min_element(shininess.begin(), shininess.end()) - shininess.begin());
  // For the shadow's f (ShadowSettings) and the hemisphere priors.
  irradiance_map_sh_ = sh_project(maps[smallest], 2);
  // The sharpest map is nearest the room's radiance: the colour priors' (made when needed).
  const std::size_t sharpest =
      std::size_t(std::max_element(shininess.begin(), shininess.end()) - shininess.begin());
  sharpest_map_ = maps[sharpest];
  set_room_sh(sh_project(maps[sharpest], 3));
  map_priors_.reset();
  ++map_generation_;
}

void SceneLighting::clear_maps() {
  maps_ = EnvSet();
  irradiance_map_sh_.reset();
  sharpest_map_.reset(), map_priors_.reset();
  ++map_generation_;
  if (last_sh_.order > 0)
    set_room_sh(last_sh_);
  else
    room_sh_ = ShCoeffs();
}

LightingSource SceneLighting::source() const {
  if (!maps_.empty()) return LightingSource::Maps;
  if (!sh_maps_.empty()) return LightingSource::Sh;
  return LightingSource::None;
}

const EnvSet& SceneLighting::maps() const {
  if (!maps_.empty()) return maps_;
  if (!sh_maps_.empty()) return sh_maps_;
  return black_;
}

glm::vec3 SceneLighting::irradiance_over_pi(glm::vec3 n) const {
  if (irradiance_map_sh_) return glm::vec3(sh_evaluate(*irradiance_map_sh_, glm::dvec3(n)));
  if (!sh_maps_.empty() && irradiance_sh_.order > 0)
    return glm::vec3(sh_evaluate(irradiance_sh_, glm::dvec3(n)));
  return glm::vec3(0.0f);
}

HemispherePriors SceneLighting::hemisphere_priors() const {
  HemispherePriors h;
  h.upper = irradiance_over_pi({0.0f, 1.0f, 0.0f});
  h.lower = irradiance_over_pi({0.0f, -1.0f, 0.0f});
  h.light = 0.0f, h.shadow = std::numeric_limits<float>::max();
  for (int i = 0; i < kHorizontalNormals; ++i) {
    const float phi = 2.0f * std::numbers::pi_v<float> * float(i) / kHorizontalNormals;
    const float l = luminance(irradiance_over_pi({std::cos(phi), 0.0f, std::sin(phi)}));
    h.light = std::max(h.light, l), h.shadow = std::min(h.shadow, l);
  }
  return h;
}

const EnvironmentPriors& SceneLighting::environment_priors() const {
  if (override_) return *override_;
  if (!maps_.empty()) {
    if (!map_priors_) map_priors_ = render::environment_priors(*sharpest_map_);
    return *map_priors_;
  }
  if (!sh_priors_) {
    const EnvLayout layout = EnvLayout::for_size(Projection::LatLong, kShMapSize);
    Image radiance = last_sh_.order > 0 ? sh_reconstruct(last_sh_, layout)
                                        : Image(layout.width(), layout.height());
    for (float& v : radiance.storage()) v = std::max(v, 0.0f);
    sh_priors_ = render::environment_priors(EnvMap(layout, std::move(radiance)));
  }
  return *sh_priors_;
}

}  // namespace arlight::render
