// Method `importance`: Colbert and Krivanek's GPU-based importance sampling ([CK07], thesis §2.3,
// §6.2.3). For each output direction d, K directions are drawn from the normalized Phong lobe
// p(w) = (s+1)/(2 pi) cos^s(theta) with a Hammersley sequence (the same pattern at every texel,
// as in [CK07], so the error is smooth rather than noisy). Because p is proportional to the
// lobe, the lobe-weighted mean is simply the mean of the samples' radiance. Each sample is read
// from the MIP level whose texels cover the solid angle the sample stands for ([CK07] eq. 13):
//   level = max(0, 1/2 log2(Omega_s / Omega_p) + 1),  Omega_s = 1 / (K p),  Omega_p = texel sr.
#include <chrono>
#include <cmath>
#include <glm/geometric.hpp>
#include <numbers>

#include "arlight/common/resample.hpp"
#include "job.hpp"

namespace arlight::lighting::detail {

namespace {

// One lobe sample in the lobe's own frame (z = lobe axis) with its density.
struct LobeSample {
  glm::dvec3 local;
  double pdf;
};

std::vector<LobeSample> lobe_samples(double s, int k) {
  std::vector<LobeSample> out;
  for (int i = 0; i < k; ++i) {
    const double u = (i + 0.5) / k, v = radical_inverse(std::uint32_t(i));
    const double cos_t = std::pow(u, 1.0 / (s + 1.0));
    const double sin_t = std::sqrt(std::max(0.0, 1.0 - cos_t * cos_t));
    const double phi = 2.0 * std::numbers::pi * v;
    out.push_back({{sin_t * std::cos(phi), sin_t * std::sin(phi), cos_t},
                   (s + 1.0) / (2.0 * std::numbers::pi) * std::pow(cos_t, s)});
  }
  return out;
}

}  // namespace

ComputedMapSet run_importance(const Job& job) {
  const auto t0 = std::chrono::steady_clock::now();
  const EnvSampler sampler(job.input);
  const int k_samples = job.spec.samples;
  std::vector<std::vector<LobeSample>> samples;
  for (double s : job.shininess) samples.push_back(lobe_samples(s, k_samples));
  std::vector<EnvMap> maps = blank_maps(job);
  const int count = int(maps.size());
  const double max_level = sampler.levels() - 1;
  for_each_tile(job.output.tiles(), job.progress, [&](const Tile& tile) {
    job.output.for_each(tile, [&](std::size_t pixel, glm::dvec3 d) {
      // An orthonormal frame around d (Frisvad / Duff et al.).
      const double sign = std::copysign(1.0, d.z);
      const double a = -1.0 / (sign + d.z), b = d.x * d.y * a;
      const glm::dvec3 t(1.0 + sign * d.x * d.x * a, sign * b, -sign * d.x);
      const glm::dvec3 bt(b, sign + d.y * d.y * a, -d.y);
      for (int m = 0; m < count; ++m) {
        glm::dvec3 sum(0.0);
        for (const LobeSample& smp : samples[std::size_t(m)]) {
          const glm::dvec3 w = smp.local.x * t + smp.local.y * bt + smp.local.z * d;
          const double omega_s = 1.0 / (k_samples * smp.pdf);
          const double omega_p = sampler.texel_solid_angle_at(w);
          const double level =
              omega_p > 0.0 ? std::clamp(0.5 * std::log2(omega_s / omega_p) + 1.0, 0.0, max_level)
                            : 0.0;
          sum += glm::dvec3(sampler.sample(w, level));
        }
        const glm::dvec3 v = sum / double(k_samples);
        float* out = maps[std::size_t(m)].image.data() + 3 * pixel;
        out[0] = float(v.x), out[1] = float(v.y), out[2] = float(v.z);
      }
    });
    for (int m = 0; m < count; ++m) job.progress.tile_done(m, tile);
  });
  return joint_result(
      std::move(maps), t0,
      std::vector<std::string>(std::size_t(count), "importance: " + std::to_string(k_samples) +
                                                       " Hammersley lobe samples"));
}

}  // namespace arlight::lighting::detail
