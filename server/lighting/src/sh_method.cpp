// Method `sh`: SH convolution (thesis Alg. 4.5-4.7). The input is projected onto SH of the
// chosen order (Alg. 4.5, eq. 2.29), each band is scaled by the normalized Phong lobe's zonal
// coefficient Lambda_l rho_l (Alg. 4.6, eq. 2.33) and the expansions are evaluated at the output
// texels (Alg. 4.7), one basis evaluation per texel shared by all maps.
#include <chrono>
#include <cmath>
#include <numbers>

#include "arlight/sh.hpp"
#include "job.hpp"

namespace arlight::lighting::detail {

ShCoeffs sh_project_mean_exact(const EnvMap& env, int order) {
  const auto table = texel_table(env.layout);
  glm::dvec3 mean(0.0);
  double total = 0.0;
  for (std::size_t i = 0; i < table->size(); ++i) {
    const float* p = env.image.data() + 3 * std::size_t(table->index[i]);
    mean += table->solid_angle[i] * glm::dvec3(p[0], p[1], p[2]);
    total += table->solid_angle[i];
  }
  mean /= total;
  EnvMap residual = env;
  for (std::uint32_t px : table->index)
    for (int c = 0; c < 3; ++c) residual.image.data()[3 * std::size_t(px) + c] -= float(mean[c]);
  ShCoeffs coeffs = sh_project(residual, order);
  coeffs.at(0, 0) += mean * std::sqrt(4.0 * std::numbers::pi);  // a constant m is m sqrt(4 pi) Y_00
  return coeffs;
}

MapSet run_sh(const Job& job) {
  const auto t0 = std::chrono::steady_clock::now();
  const int order = job.spec.sh_order;
  const ShCoeffs coeffs = sh_project_mean_exact(job.input, order);
  job.progress.check();
  std::vector<ShCoeffs> convolved;
  for (double s : job.shininess) convolved.push_back(sh_convolve(coeffs, phong_zonal_all(order, s)));
  std::vector<EnvMap> maps = blank_maps(job);
  const int count = int(maps.size());
  for_each_tile(job.output.tiles(), job.progress, [&](const Tile& tile) {
    std::vector<glm::dvec3> dirs;
    std::vector<std::size_t> pixels;
    job.output.for_each(tile, [&](std::size_t pixel, glm::dvec3 d) {
      dirs.push_back(d);
      pixels.push_back(pixel);
    });
    std::vector<std::vector<float>> values(std::size_t(count), std::vector<float>(3 * dirs.size()));
    std::vector<float*> out;
    for (auto& v : values) out.push_back(v.data());
    sh_evaluate_many(convolved, dirs, out);
    for (int k = 0; k < count; ++k) {
      float* img = maps[std::size_t(k)].image.data();
      for (std::size_t i = 0; i < pixels.size(); ++i)
        for (int c = 0; c < 3; ++c) img[3 * pixels[i] + c] = values[std::size_t(k)][3 * i + c];
      job.progress.tile_done(k, tile);
    }
  });
  MapSet result;
  result.maps = std::move(maps);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  result.seconds.assign(std::size_t(count), seconds / count);
  result.plans.assign(std::size_t(count), "sh: order " + std::to_string(order));
  return result;
}

}  // namespace arlight::lighting::detail
