// The GGX BRDF of glTF metallic-roughness and the split sum's DFG table (brdf.hpp).
#include "arlight/common/brdf.hpp"

#include <algorithm>
#include <cmath>
#include <glm/geometric.hpp>
#include <numbers>
#include <string>

#include "arlight/common/error.hpp"

namespace arlight {

double ggx_distribution(double n_dot_h, double a2) {
  const double d = n_dot_h * n_dot_h * (a2 - 1.0) + 1.0;
  return a2 / (std::numbers::pi * d * d);
}

double ggx_visibility(double n_dot_v, double n_dot_l, double a2) {
  const double lv = n_dot_l * std::sqrt(n_dot_v * n_dot_v * (1.0 - a2) + a2);
  const double ll = n_dot_v * std::sqrt(n_dot_l * n_dot_l * (1.0 - a2) + a2);
  return 0.5 / (lv + ll);
}

glm::dvec3 schlick_fresnel(const glm::dvec3& f0, double v_dot_h) {
  return f0 + (1.0 - f0) * std::pow(1.0 - std::clamp(v_dot_h, 0.0, 1.0), 5.0);
}

glm::dvec3 metallic_roughness_brdf(const glm::dvec3& n, const glm::dvec3& l, const glm::dvec3& v,
                                   const glm::dvec3& base, double metallic, double roughness) {
  const double nl = glm::dot(n, l), nv = glm::dot(n, v);
  if (nl <= 0.0 || nv <= 0.0) return glm::dvec3(0.0);
  const glm::dvec3 h = glm::normalize(l + v);
  const double alpha = roughness * roughness, a2 = std::max(alpha * alpha, 1e-12);
  const double specular = ggx_distribution(glm::dot(n, h), a2) * ggx_visibility(nv, nl, a2);
  // glTF Appendix B: mix(dielectric, metal, metallic), the dielectric's Fresnel (F0 = 0.04)
  // taking its share from the diffuse: (1 - m)(1 - F_0.04) diffuse + F_mix specular, as F is
  // linear in F0 (F_mix: F0 = mix(0.04, base, metallic)).
  const double vh = glm::dot(v, h);
  const glm::dvec3 f = schlick_fresnel(glm::mix(glm::dvec3(0.04), base, metallic), vh);
  const double f_dielectric = schlick_fresnel(glm::dvec3(0.04), vh).x;
  return (1.0 - f_dielectric) * (1.0 - metallic) * base / std::numbers::pi + f * specular;
}

GgxMultipleScattering::GgxMultipleScattering(double roughness, int table, int samples) {
  if (table < 2 || samples < 1) throw InputError("multiple scattering: bad table or sample count");
  albedo_.resize(std::size_t(table));
  average_ = 0.0;
  for (int i = 0; i < table; ++i) {
    const double mu = (i + 0.5) / table;
    albedo_[std::size_t(i)] = std::min(1.0, double(dfg_value(mu, roughness, samples).y));
    average_ += 2.0 * albedo_[std::size_t(i)] * mu / table;
  }
}

double GgxMultipleScattering::albedo(double n_dot_v) const {
  const double x = std::clamp(n_dot_v, 0.0, 1.0) * double(albedo_.size()) - 0.5;
  const int i = std::clamp(int(std::floor(x)), 0, int(albedo_.size()) - 2);
  const double t = std::clamp(x - i, 0.0, 1.0);
  return (1.0 - t) * albedo_[std::size_t(i)] + t * albedo_[std::size_t(i) + 1];
}

glm::dvec3 GgxMultipleScattering::brdf(double n_dot_l, double n_dot_v, const glm::dvec3& f0) const {
  if (n_dot_l <= 0.0 || n_dot_v <= 0.0 || average_ >= 1.0) return glm::dvec3(0.0);
  const glm::dvec3 f_avg = (20.0 * f0 + 1.0) / 21.0;
  const glm::dvec3 f_ms = f_avg * f_avg * average_ / (1.0 - f_avg * (1.0 - average_));
  return f_ms * ((1.0 - albedo(n_dot_l)) * (1.0 - albedo(n_dot_v)) /
                 (std::numbers::pi * (1.0 - average_)));
}

glm::vec2 dfg_value(double n_dot_v, double roughness, int samples) {
  const double nv = std::clamp(n_dot_v, 1e-6, 1.0);
  const double alpha = roughness * roughness, a2 = alpha * alpha;
  const double vx = std::sqrt(1.0 - nv * nv), vz = nv;  // v in the x-z plane, n = +z
  double a = 0.0, b = 0.0;
  for (int i = 0; i < samples; ++i) {
    // GGX-distributed half vector (pdf D(h) n.h).
    const double u1 = double(i) / double(samples), u2 = radical_inverse(std::uint32_t(i));
    const double phi = 2.0 * std::numbers::pi * u1;
    const double cos2 = (1.0 - u2) / (1.0 + (a2 - 1.0) * u2);
    const double ct = std::sqrt(cos2), st = std::sqrt(std::max(0.0, 1.0 - cos2));
    const double hx = st * std::cos(phi), hz = ct;  // h.y does not enter: v lies in the x-z plane
    const double v_dot_h = vx * hx + vz * hz;
    const double lz = 2.0 * v_dot_h * hz - vz;  // n.l of l = reflect(-v, h)
    if (lz <= 0.0 || v_dot_h <= 0.0) continue;
    // BRDF x n.l / pdf(l) with pdf(l) = D n.h / (4 v.h): 4 V n.l v.h / n.h.
    const double v = ggx_visibility(nv, lz, a2) * lz * v_dot_h / hz;
    const double fc = std::pow(1.0 - v_dot_h, 5.0);
    a += v * fc;
    b += v;
  }
  return glm::vec2(float(4.0 * a / samples), float(4.0 * b / samples));
}

double DfgTable::average_albedo(int j) const {
  double average = 0.0;
  for (int i = 0; i < size; ++i) average += 2.0 * double(at(i, j).y) * (i + 0.5) / size / size;
  return std::min(average, 1.0);
}

DfgTable dfg_table(int size, int samples) {
  if (size < 1 || size > 4096)
    throw InputError("DFG table: size must lie in [1, 4096], got " + std::to_string(size));
  if (samples < 1)
    throw InputError("DFG table: samples must be positive, got " + std::to_string(samples));
  DfgTable t{size, std::vector<glm::vec2>(std::size_t(size) * std::size_t(size))};
  for (int j = 0; j < size; ++j) {
    const double roughness = 1.0 - (j + 0.5) / size;
    for (int i = 0; i < size; ++i)
      t.ab[std::size_t(j) * std::size_t(size) + std::size_t(i)] =
          dfg_value((i + 0.5) / size, roughness, samples);
  }
  return t;
}

}  // namespace arlight
