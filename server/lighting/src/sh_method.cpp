// Method `sh`: SH convolution (thesis Alg. 4.5-4.7). The input is projected onto SH of the
// chosen order (Alg. 4.5, eq. 2.29), each band is scaled by the normalized Phong lobe's zonal
// coefficient Lambda_l rho_l (Alg. 4.6, eq. 2.33) and the expansions are evaluated at the output
// texels (Alg. 4.7), one basis evaluation per texel shared by all maps.
#include <chrono>
#include <cmath>
#include <map>
#include <memory>
#include <mutex>
#include <numbers>
#include <tuple>

#include "arlight/common/sh.hpp"
#include "job.hpp"

namespace arlight::lighting::detail {

ShPair sh_project_pair(const EnvMap& env, int order) {
  // The weights' projection depends only on the layout and order: computed once, then shared.
  static std::mutex mutex;
  static std::map<std::tuple<int, int, int, int>, std::shared_ptr<const ShCoeffs>> cache;
  const auto key =
      std::tuple{int(env.layout.projection()), env.layout.width(), env.layout.height(), order};
  std::shared_ptr<const ShCoeffs> weight;
  {
    std::lock_guard lock(mutex);
    if (auto it = cache.find(key); it != cache.end()) weight = it->second;
  }
  if (!weight) {
    EnvMap ones(env.layout);
    for (std::uint32_t px : texel_table(env.layout)->index)
      for (int c = 0; c < 3; ++c) ones.image.data()[3 * std::size_t(px) + c] = 1.0f;
    weight = std::make_shared<const ShCoeffs>(sh_project(ones, order));
    std::lock_guard lock(mutex);
    cache.emplace(key, weight);
  }
  return {sh_project(env, order), *weight};
}

std::vector<ShCoeffs> sh_convolve_pair(const ShPair& pair, int order,
                                       std::span<const double> shininess) {
  auto truncate = [&](const ShCoeffs& c) {
    ShCoeffs t(order);
    std::copy_n(c.c.begin(), t.c.size(), t.c.begin());
    return t;
  };
  const ShCoeffs radiance = truncate(pair.radiance), weight = truncate(pair.weight);
  std::vector<ShCoeffs> out;
  for (double s : shininess) out.push_back(sh_convolve(radiance, phong_zonal_all(order, s)));
  // The weights are one channel: three maps' weight expansions share one RGB expansion.
  for (std::size_t k = 0; k < shininess.size(); k += 3) {
    ShCoeffs packed(order);
    for (std::size_t j = 0; j < 3 && k + j < shininess.size(); ++j) {
      const std::vector<double> zonal = phong_zonal_all(order, shininess[k + j]);
      for (int l = 0; l < order; ++l)
        for (int m = -l; m <= l; ++m)
          packed.at(l, m)[int(j)] = weight.at(l, m).x * zonal[std::size_t(l)];
    }
    out.push_back(std::move(packed));
  }
  return out;
}

std::size_t sh_pair_outputs(std::size_t maps) { return maps + (maps + 2) / 3; }

void sh_divide(std::span<float* const> values, std::size_t maps, std::size_t count) {
  for (std::size_t k = 0; k < maps; ++k) {
    const float* den = values[maps + k / 3];
    for (std::size_t i = 0; i < count; ++i) {
      const float w = den[3 * i + k % 3];
      for (int c = 0; c < 3; ++c) {
        float& v = values[k][3 * i + std::size_t(c)];
        v = w > 0.0f ? std::max(0.0f, v / w) : 0.0f;
      }
    }
  }
}

ComputedMapSet run_sh(const Job& job) {
  const auto t0 = std::chrono::steady_clock::now();
  const int order = job.spec.sh_order;
  const ShPair pair = sh_project_pair(job.input, order);
  job.progress.check();
  const std::vector<ShCoeffs> convolved = sh_convolve_pair(pair, order, job.shininess);
  std::vector<EnvMap> maps = blank_maps(job);
  const int count = int(maps.size());
  for_each_tile(job.output.tiles(), job.progress, [&](const Tile& tile) {
    const auto [dirs, pixels] = job.output.collect(tile);
    std::vector<std::vector<float>> values(sh_pair_outputs(std::size_t(count)),
                                           std::vector<float>(3 * dirs.size()));
    std::vector<float*> out;
    for (auto& v : values) out.push_back(v.data());
    sh_evaluate_many(convolved, dirs, out);
    sh_divide(out, std::size_t(count), dirs.size());
    for (int k = 0; k < count; ++k) {
      float* img = maps[std::size_t(k)].image.data();
      for (std::size_t i = 0; i < pixels.size(); ++i)
        for (int c = 0; c < 3; ++c) img[3 * pixels[i] + c] = values[std::size_t(k)][3 * i + c];
      job.progress.tile_done(k, tile);
    }
  });
  return joint_result(
      std::move(maps), t0,
      std::vector<std::string>(std::size_t(count), "sh: order " + std::to_string(order)));
}

}  // namespace arlight::lighting::detail
