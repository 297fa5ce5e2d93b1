// Internal: the room's light as the renderer holds it, and what the passes derive from it.
// The map set (thesis ch. 4's irradiance and reflection maps), or until it arrives the live
// SH's small lat-long maps (thesis eq. 2.33); from either: the irradiance at a normal (the
// shadow's f, hemisphere shading), the room's SH-9 (the meshes' transfer), the colour priors
// (dissertation §5.1) and the sharpest map (the shadow's light clusters). GL-bound only through
// the maps' textures.
#pragma once

#include <cstddef>
#include <optional>
#include <tuple>
#include <vector>

#include "arlight/common/projection.hpp"
#include "arlight/common/sh.hpp"
#include "arlight/render/render.hpp"
#include "gl.hpp"

namespace arlight::render {

// A set of environment maps of one projection on the GPU, sorted by shininess.
struct EnvSet {
  Projection projection = Projection::LatLong;
  std::vector<double> shininess;
  std::vector<gl::Texture> tex;
  std::vector<glm::ivec2> size;
  bool empty() const { return tex.empty(); }

  // Uploads maps (sorted by shininess), re-using textures of the same count and sizes.
  void upload(const std::vector<double>& s, const std::vector<EnvMap>& maps);
  // The two maps around shininess s and the weight of the second (log-shininess interpolation),
  // or the nearest one (weight 0).
  std::tuple<std::size_t, std::size_t, float> pick(double s, ReflectionLookup lookup) const;
};

class SceneLighting {
 public:
  SceneLighting();  // uploads the black map used before any lighting: needs a current context

  // Renderer::set_sh / set_maps / clear_maps (their contracts are render.hpp's).
  void set_sh(const ShCoeffs& sh);
  void set_maps(const std::vector<double>& shininess, const std::vector<EnvMap>& maps);
  void clear_maps();
  LightingSource source() const;

  // Renderer::set_ggx_chain / clear_ggx_chain.
  void set_ggx_chain(const std::vector<EnvMap>& levels, const std::vector<double>& roughness,
                     const std::vector<SpecularLight>& lights);
  void clear_ggx_chain() { ggx_ = gl::Texture(), ggx_levels_ = 0, ggx_lights_.clear(); }
  // The GGX chain's cube texture (mip level k = chain level k) and its level count; 0 levels:
  // none (metallic-roughness then takes its specular from the reflection maps).
  GLuint ggx_chain() const { return ggx_.id; }
  int ggx_levels() const { return ggx_levels_; }
  // The lights taken out of the chain's room (world frame; empty: the chain is the whole room).
  const std::vector<SpecularLight>& ggx_lights() const { return ggx_lights_; }

  // What the objects are shaded with now: the map set, the live SH's maps, or black.
  const EnvSet& maps() const;
  // The room's radiance SH, bands 0-2 (world frame), for the meshes' transfer: the sharpest
  // map's under a map set (nearest the radiance), else the live SH's; order 0 before any.
  const ShCoeffs& room_sh() const { return room_sh_; }
  // Lbar(n) = irradiance / pi at world direction n (0 without lighting).
  glm::vec3 irradiance_over_pi(glm::vec3 n) const;
  HemispherePriors hemisphere_priors() const;
  // The room's colour priors, made when first asked for (a colour correction): the page must
  // not spend its frame time on them with every LightingUpdate.
  const EnvironmentPriors& environment_priors() const;
  void set_environment_priors(std::optional<EnvironmentPriors> priors) { override_ = priors; }
  // The map set's sharpest map (nearest the room's radiance), or null under the live SH.
  const EnvMap* sharpest_map() const { return sharpest_map_ ? &*sharpest_map_ : nullptr; }
  // Changes whenever sharpest_map() does (what is derived from it must be made again).
  unsigned map_generation() const { return map_generation_; }

 private:
  void set_room_sh(const ShCoeffs& sh);

  EnvSet maps_, sh_maps_, black_;
  gl::Texture ggx_;
  int ggx_levels_ = 0;
  std::vector<SpecularLight> ggx_lights_;
  ShCoeffs last_sh_, room_sh_;
  ShCoeffs irradiance_sh_;  // the live SH's irradiance / pi
  // The irradiance map's bands 0-2 (irradiance is smooth: they hold nearly all of it), so a
  // value at any direction is smooth too, not the nearest texel's.
  std::optional<ShCoeffs> irradiance_map_sh_;
  std::optional<EnvMap> sharpest_map_;
  unsigned map_generation_ = 0;
  mutable std::optional<EnvironmentPriors> sh_priors_, map_priors_;
  std::optional<EnvironmentPriors> override_;
};

}  // namespace arlight::render
