// Filtered lookups into an environment map by direction, and resampling between projections
// and sizes without aliasing.
#pragma once

#include <glm/vec3.hpp>
#include <vector>

#include "arlight/common/image.hpp"
#include "arlight/common/projection.hpp"

namespace arlight {

// A solid-angle-weighted MIP chain of an environment map. Level k+1 is the area-correct 2x
// reduction of level k in which every texel is weighted by the solid angle it covers, so each
// coarse texel is the mean radiance over its patch of the sphere (cube faces reduce separately;
// texels outside an angle map's disk carry no weight and never bleed in).
class EnvSampler {
 public:
  explicit EnvSampler(const EnvMap& env);

  int levels() const { return int(levels_.size()); }
  const EnvLayout& layout() const { return layout_; }

  // Trilinear lookup (bilinear in the two nearest levels) at a fractional level >= 0.
  glm::vec3 sample(glm::dvec3 dir, double level = 0.0) const;

  // Solid angle of the level-0 texel that `dir` falls in.
  double texel_solid_angle_at(glm::dvec3 dir) const;

 private:
  struct Level {
    int width, height;
    Image image;
    std::vector<float> weight;  // summed solid angle per texel (0 = not on the sphere)
  };
  glm::vec3 sample_level(const Level& lv, glm::dvec2 uv, int face) const;

  EnvLayout layout_;
  std::vector<Level> levels_;
};

// Resamples `src` into `dst`'s projection and size. Each destination texel averages n x n
// stratified sub-samples (n up to 4) taken from the source MIP level whose texels match the
// sub-sample spacing, so shrinking never aliases and enlarging is bilinear. Texels of `dst`
// not on the sphere stay 0.
EnvMap resample(const EnvMap& src, const EnvLayout& dst);

// `src` reduced to `dst` when both are cube maps and dst's face divides src's by a whole factor
// k: each texel the solid-angle-weighted mean of the k x k texels it covers, so the map's power
// is kept exactly (a box filter on the stacked faces; ~20x faster than resample(), which it
// matches to within its sub-sampling). Other layouts are binned: each texel of `dst` the
// solid-angle-weighted mean of the texels of `src` whose centres fall in it (the power within
// ~1 %; ~10x faster than resample()), when `src` has at least twice the texels and every texel
// of `dst` gets one. Otherwise resample(src, dst).
EnvMap reduce(const EnvMap& src, const EnvLayout& dst);

}  // namespace arlight
