// Method `mipmap`: the MIP-mapping approximation of thesis §4.2, reproduced as the thesis ran it.
// The input becomes an N x N angle map (N a power of two), glGenerateMipmap's plain 2x2 box
// pyramid is built over it (not weighted by solid angle, as on the GPU), and each output direction
// samples it with trilinear filtering (textureLod, GL_LINEAR_MIPMAP_LINEAR, clamp to edge) at
//   l_irrad = l_max - 2                                (eq. 4.2, s = 1)
//   l_rad   = l_max - log2(min(max(s / 2, 4), N))      (eq. 4.3, s > 1)
// with l_max = log2(N) (eq. 4.1). One deviation: texels outside the disk do not count in the
// box averages. glGenerateMipmap would average the black corners into the rim, darkening the
// coarse levels there even for a constant environment; that is a GPU artefact, not the method.
#include <bit>
#include <chrono>
#include <cmath>
#include <glm/common.hpp>
#include <numbers>

#include "arlight/common/resample.hpp"
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

// Bilinear lookup (clamp to edge) in which each texel counts by the part of it on the disk, so
// the black outside never bleeds into the rim.
glm::vec3 sample_covered(const Image& img, const std::vector<float>& cover, glm::dvec2 uv) {
  const double px = uv.x * img.width() - 0.5, py = uv.y * img.height() - 0.5;
  const int x0 = int(std::floor(px)), y0 = int(std::floor(py));
  const double tx = px - x0, ty = py - y0;
  glm::dvec3 sum(0.0);
  double weight = 0.0;
  for (int j = 0; j < 2; ++j)
    for (int i = 0; i < 2; ++i) {
      const int x = std::clamp(x0 + i, 0, img.width() - 1),
                y = std::clamp(y0 + j, 0, img.height() - 1);
      const double w = (i ? tx : 1.0 - tx) * (j ? ty : 1.0 - ty) *
                       cover[std::size_t(y) * std::size_t(img.width()) + std::size_t(x)];
      sum += w * glm::dvec3(img.at(x, y));
      weight += w;
    }
  return weight > 0.0 ? glm::vec3(sum / weight) : glm::vec3(0.0f);
}

}  // namespace

double mipmap_level(double s, int n) {
  const double l_max = std::log2(double(n));                              // eq. 4.1
  if (s == 1.0) return std::max(0.0, l_max - 2.0);                        // eq. 4.2
  return l_max - std::log2(std::min(std::max(s / 2.0, 4.0), double(n)));  // eq. 4.3
}

ComputedMapSet run_mipmap(const Job& job) {
  const auto t0 = std::chrono::steady_clock::now();
  const EnvMap angle = working_angle_map(job.input);
  // Each level with the fraction of each texel that lies on the disk.
  std::vector<Image> pyramid{angle.image};
  std::vector<std::vector<float>> coverage(1, std::vector<float>(angle.image.texel_count(), 0.0f));
  for (std::uint32_t i : texel_table(angle.layout)->index) coverage[0][i] = 1.0f;
  while (pyramid.back().width() > 1) {
    std::vector<float> sum;
    pyramid.push_back(downsample2x(pyramid.back().view(), coverage.back().data(), &sum));
    const float area = float(angle.image.texel_count()) / float(pyramid.back().texel_count());
    for (float& v : sum) v /= area;
    coverage.push_back(std::move(sum));
  }
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
          return sample_covered(pyramid[std::size_t(li)], coverage[std::size_t(li)], uv);
        };
        glm::vec3 v = at(l0);
        if (t > 0.0) v = glm::mix(v, at(l1), float(t));
        float* out = maps[std::size_t(k)].image.data() + 3 * pixel;
        out[0] = v.x, out[1] = v.y, out[2] = v.z;
      }
    });
    for (int k = 0; k < count; ++k) job.progress.tile_done(k, tile);
  });
  std::vector<std::string> plans;
  for (double l : level)
    plans.push_back("mipmap: level " + std::to_string(l) + " of a " + std::to_string(n) +
                    "^2 angle map");
  return joint_result(std::move(maps), t0, std::move(plans));
}

}  // namespace arlight::lighting::detail
