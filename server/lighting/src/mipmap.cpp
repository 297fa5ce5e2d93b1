// Method `mipmap`: the MIP-mapping approximation of thesis §4.2, reproduced as the thesis ran it.
// The input becomes an N x N angle map (N a power of two), glGenerateMipmap's plain 2x2 box
// pyramid is built over the whole square (black corners included), and each output direction
// samples it with trilinear filtering (textureLod, GL_LINEAR_MIPMAP_LINEAR, clamp to edge) at
//   l_irrad = l_max - 2                                (eq. 4.2, s = 1)
//   l_rad   = l_max - log2(min(max(s / 2, 4), N))      (eq. 4.3, s > 1)
// with l_max = log2(N) (eq. 4.1).
#include <bit>
#include <chrono>
#include <cmath>
#include <glm/common.hpp>
#include <numbers>

#include "arlight/resample.hpp"
#include "job.hpp"

namespace arlight::lighting::detail {

namespace {

// The angle map the thesis would have had: the input itself when it already is a power-of-two
// angle map, otherwise the input resampled to the power-of-two angle map closest in texel count.
EnvMap working_angle_map(const EnvMap& input) {
  const EnvLayout& in = input.layout;
  if (in.projection() == Projection::AngleMap && std::has_single_bit(unsigned(in.width())))
    return input;
  const double valid = double(texel_table(in)->size());
  const double side = std::sqrt(valid * 4.0 / std::numbers::pi);
  const unsigned n = std::bit_floor(unsigned(std::max(4.0, side * std::numbers::sqrt2)));
  return resample(input, EnvLayout::for_size(Projection::AngleMap, int(n)));
}

}  // namespace

double mipmap_level(double s, int n) {
  const double l_max = std::log2(double(n));                               // eq. 4.1
  if (s == 1.0) return std::max(0.0, l_max - 2.0);                        // eq. 4.2
  return l_max - std::log2(std::min(std::max(s / 2.0, 4.0), double(n)));  // eq. 4.3
}

MapSet run_mipmap(const Job& job) {
  const auto t0 = std::chrono::steady_clock::now();
  const EnvMap angle = working_angle_map(job.input);
  const std::vector<Image> pyramid = build_mip_pyramid(angle.image);
  const int n = angle.layout.width();
  std::vector<double> level;
  for (double s : job.shininess) level.push_back(mipmap_level(s, n));
  std::vector<EnvMap> maps = blank_maps(job);
  const int count = int(job.shininess.size());
  for_each_tile(job.output.tiles(), job.progress, [&](const Tile& tile) {
    job.output.for_each(tile, [&](std::size_t pixel, glm::dvec3 d) {
      const glm::dvec2 uv = angle.layout.dir_to_uv(d);
      for (int k = 0; k < count; ++k) {
        const double l = std::clamp(level[std::size_t(k)], 0.0, double(pyramid.size() - 1));
        const int l0 = int(std::floor(l)), l1 = std::min(l0 + 1, int(pyramid.size()) - 1);
        const double t = l - l0;
        auto at = [&](int li) {
          const Image& img = pyramid[std::size_t(li)];
          return sample_bilinear(img.view(), uv.x * img.width(), uv.y * img.height());
        };
        glm::vec3 v = at(l0);
        if (t > 0.0) v = glm::mix(v, at(l1), float(t));
        float* out = maps[std::size_t(k)].image.data() + 3 * pixel;
        out[0] = v.x, out[1] = v.y, out[2] = v.z;
      }
    });
    for (int k = 0; k < count; ++k) job.progress.tile_done(k, tile);
  });
  MapSet result;
  result.maps = std::move(maps);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  result.seconds.assign(std::size_t(count), seconds / count);
  for (double l : level)
    result.plans.push_back("mipmap: level " + std::to_string(l) + " of a " + std::to_string(n) +
                           "^2 angle map");
  return result;
}

}  // namespace arlight::lighting::detail
