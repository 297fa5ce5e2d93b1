// The room's small, bright lights taken out of its environment for the specular part (issue 51
// §1): the split sum (Karis 2013) prefilters the environment with the n = v = R lobe, so a sun or
// a lamp, whose light sits in a few texels, reaches a metal through a lobe of the wrong shape (the
// BRDF's stretches at grazing views) and a blurred level's texel. Taken out as analytic lights,
// each shaded with the full GGX BRDF (Karis's representative point and widened lobe for its
// disc), they leave the chain only what remains: the residual, smooth enough for the split sum.
//
// The split is exact: every texel brighter than `threshold` x the map's mean luminance gives its
// excess over `floor` x that mean (its colour kept) to a light; the lights are those texels split
// top-down at the middle of their widest extent while a cluster is not compact (two lamps, a
// long tube), and a cluster still not compact, or wider than `max_radius`, gives its excess back. So
// residual + the lights' texels = the map, texel by texel, and the lights' power + the residual's
// is the map's.
#pragma once

#include <cmath>
#include <glm/geometric.hpp>
#include <glm/vec3.hpp>
#include <numbers>
#include <vector>

#include "arlight/common/projection.hpp"

namespace arlight {

inline constexpr int kMaxSpecularLights = 8;  // shaders/ibl.frag's GGX_LIGHTS arrays

struct SpecularLight {
  glm::vec3 direction{0.0f, 1.0f, 0.0f};  // unit, towards the light: its excess's centroid
  // Its excess radiance x solid angle, summed (RGB): the irradiance it gives a surface facing it.
  glm::vec3 power{0.0f};
  // Angular radius (rad) of the uniform disc with its texels' second moment about `direction`
  // (each texel counted as a disc of its own solid angle): a single texel's is sqrt(w / pi).
  float radius = 0.0f;
  bool operator==(const SpecularLight&) const = default;
};

struct SpecularSplitOptions {
  // x the map's mean luminance (solid-angle weighted); > 1. Lower takes a sun's halo with its
  // core, and the disc the shader assumes is then too wide for a mirror (bench/RESULTS.md,
  // issue 51: park's sun 0.8 degrees at 128, 2.2 at 32).
  double threshold = 128.0;
  double floor = 1.0;  // x the mean: the luminance a light's texels keep; in (0, threshold]
  int max_lights = kMaxSpecularLights;  // in [0, kMaxSpecularLights]
  double max_radius = 0.25;             // rad; (0, pi/2]
};

struct SpecularSplit {
  std::vector<SpecularLight> lights;  // brightest (luminance of power) first
  EnvMap residual;                    // the map less the lights' excess, same layout
};

// Why `light` cannot be shaded (its direction not unit, its radius outside [0, pi/2), its
// power below 0 or not finite), or null: what the renderer and the wire both check (inline: the
// page's light module decodes lights without the split).
inline const char* specular_light_problem(const SpecularLight& light) {
  if (!(std::abs(glm::length(light.direction) - 1.0f) < 1e-3f)) return "its direction is not a unit vector";
  if (!(light.radius >= 0.0f && light.radius < 0.5f * std::numbers::pi_v<float>))
    return "its radius is not in [0, pi/2)";
  const glm::vec3 p = light.power;
  if (!(p.x >= 0.0f && p.y >= 0.0f && p.z >= 0.0f) || !std::isfinite(p.x + p.y + p.z))
    return "its power is not finite and >= 0";
  return nullptr;
}

// Throws std::invalid_argument for options out of range. A map with no texel above the
// threshold (or max_lights 0) gives no lights and the map itself as the residual.
SpecularSplit split_specular_lights(const EnvMap& map, const SpecularSplitOptions& options = {});

}  // namespace arlight
