#include "shadow_lights.hpp"

#include <algorithm>
#include <numbers>

namespace arlight::render {

float dominant_fraction(const ShadowSettings& shadow, const SceneLighting& lighting,
                        const glm::mat3& world_from_scene) {
  if (!shadow.enabled) return 0.0f;
  const glm::vec3 up = world_from_scene * glm::vec3(0, 0, 1);
  const float len = glm::length(shadow.light_direction);
  if (!(len > 0)) return 0.0f;
  const float cos_l = std::max(0.0f, glm::dot(shadow.light_direction / len, up));
  const float e_dom = luminance(shadow.light_colour) * cos_l;
  if (!(e_dom > 0)) return 0.0f;
  const float e_tot = std::numbers::pi_v<float> * luminance(lighting.irradiance_over_pi(up));
  const float f = e_tot > 0 ? e_dom / e_tot : 1.0f;
  return std::clamp(f, 0.0f, std::clamp(shadow.max_fraction, 0.0f, 1.0f));
}

std::vector<ShadowLight> ShadowLightChooser::choose(const ShadowSettings& shadow,
                                                    const SceneLighting& lighting,
                                                    const glm::mat3& world_from_scene) const {
  std::vector<ShadowLight> lights;
  if (!shadow.enabled) return lights;
  const glm::mat3 scene_from_world = glm::transpose(world_from_scene);
  const glm::vec3 up = world_from_scene * glm::vec3(0, 0, 1);
  const auto add = [&](glm::vec3 world_direction, float f, glm::vec3 power) {
    const glm::vec3 l = glm::normalize(scene_from_world * world_direction);
    if (f > 0.0f && l.z > 0.02f) lights.push_back({l, f, glm::normalize(world_direction), power});
  };
  if (const EnvMap* sharpest = lighting.sharpest_map()) {
    if (!tree_ || tree_generation_ != lighting.map_generation() ||
        tree_share_ != shadow.source_share || glm::dot(tree_->normal, up) < 0.9994f) {
      LightTreeOptions o;
      o.power_share = std::clamp(double(shadow.source_share), 0.01, 1.0);
      o.max_leaves = kMaxShadowLights;
      tree_ = build_light_tree(*sharpest, glm::dvec3(up), o);
      tree_share_ = shadow.source_share;
      tree_generation_ = lighting.map_generation();
    }
    const float total = luminance(tree_->receiver_irradiance);
    for (const int i : select_lights(*tree_, std::clamp(shadow.lights, 1, kMaxShadowLights))) {
      const LightCluster& c = tree_->nodes[std::size_t(i)];
      if (total > 0.0f && c.spread <= shadow.max_spread)
        add(c.direction, luminance(c.irradiance) / total,
            c.irradiance / std::max(glm::dot(c.direction, up), 0.05f));
    }
  } else if (glm::length(shadow.light_direction) > 0.0f) {
    add(shadow.light_direction, dominant_fraction(shadow, lighting, world_from_scene),
        shadow.light_colour);
  }
  float sum = 0.0f;
  for (const ShadowLight& l : lights) sum += l.fraction;
  const float cap = std::clamp(shadow.max_fraction, 0.0f, 1.0f);
  if (sum > cap)
    for (ShadowLight& l : lights) l.fraction *= cap / sum, l.power *= cap / sum;
  return lights;
}

float ShadowLightChooser::fraction(const ShadowSettings& settings, const SceneLighting& lighting,
                                   const glm::mat3& world_from_scene) const {
  float sum = 0.0f;
  for (const ShadowLight& l : choose(settings, lighting, world_from_scene)) sum += l.fraction;
  return sum;
}

}  // namespace arlight::render
