// The exact GGX prefilter: the lobe-weighted mean over every input texel (as thesis Alg. 4.1's
// accurate method sums the Phong lobe), in double. The reference the hierarchical sum
// (ggx.cpp) is measured against.
#include <tbb/parallel_for.h>

#include <cmath>

#include "arlight/common/error.hpp"
#include "arlight/lighting/ggx.hpp"

namespace arlight::lighting {

std::vector<glm::dvec3> ggx_prefilter_exact(const EnvMap& input, double roughness,
                                            std::span<const glm::dvec3> dirs) {
  if (!(roughness > 0.0 && roughness <= 1.0))
    throw InputError("GGX prefilter: roughness must lie in (0, 1], got " + std::to_string(roughness));
  const TexelTable& table = *texel_table(input.layout);
  const double alpha = roughness * roughness, a2 = alpha * alpha;
  const float* px = input.image.data();
  std::vector<glm::dvec3> out(dirs.size());
  tbb::parallel_for(std::size_t(0), dirs.size(), [&](std::size_t q) {
    const glm::dvec3 r = dirs[q];
    glm::dvec3 sum(0.0);
    double weight = 0.0;
    for (std::size_t e = 0; e < table.size(); ++e) {
      const double dx = r.x - table.x[e], dy = r.y - table.y[e], dz = r.z - table.z[e];
      const double u = 0.5 * (dx * dx + dy * dy + dz * dz);  // 1 - R.l
      const double c = 1.0 - u;
      if (c <= 0.0) continue;
      // D(h) (R.l) up to a constant: n.h^2 = (1 + c) / 2, D ~ 1 / (n.h^2 (a2 - 1) + 1)^2.
      const double t = a2 + 0.5 * u * (1.0 - a2);
      const double f = c / (t * t) * table.solid_angle[e];
      const float* l = px + 3 * std::size_t(table.index[e]);
      sum += f * glm::dvec3(l[0], l[1], l[2]);
      weight += f;
    }
    out[q] = weight > 0.0 ? sum / weight : glm::dvec3(0.0);
  });
  return out;
}

}  // namespace arlight::lighting
