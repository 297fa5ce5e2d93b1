// Internal: which hard shadows the shadow catcher blends (ShadowSettings, tutorial §6). Under a
// map set, the light clusters of its sharpest map (build_light_tree, select_lights) built for
// the floor's normal; under the live SH alone, the dominant light arlightd sends, with its
// share f of the floor's irradiance. No GL calls: the choice is the lighting's and the settings'.
#pragma once

#include <optional>
#include <vector>

#include "arlight/common/light_sources.hpp"
#include "arlight/render/render.hpp"
#include "scene_lighting.hpp"

namespace arlight::render {

struct ShadowLight {
  glm::vec3 direction;  // unit, scene frame, above the floor
  float fraction;       // its f_i: share of the floor's irradiance
  glm::vec3 world_direction;
  glm::vec3 power;  // radiance x solid angle (RGB): its SH is power Y_lm(world_direction)
};

class ShadowLightChooser {
 public:
  // The hard shadows this frame blends; their fractions sum to at most settings.max_fraction.
  // Empty when shadows are off.
  std::vector<ShadowLight> choose(const ShadowSettings& settings, const SceneLighting& lighting,
                                  const glm::mat3& world_from_scene) const;
  // Their fractions' sum: ShadowSettings' f.
  float fraction(const ShadowSettings& settings, const SceneLighting& lighting,
                 const glm::mat3& world_from_scene) const;

 private:
  // The map set's clusters, rebuilt when the map, the source share or the floor's normal (by
  // more than ~2 degrees) changes.
  mutable std::optional<LightTree> tree_;
  mutable float tree_share_ = 0;
  mutable unsigned tree_generation_ = 0;
};

// The dominant light's f (ShadowSettings), for lighting without a map set.
float dominant_fraction(const ShadowSettings& settings, const SceneLighting& lighting,
                        const glm::mat3& world_from_scene);

}  // namespace arlight::render
