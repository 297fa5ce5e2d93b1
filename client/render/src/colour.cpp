#include "arlight/render/colour.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <glm/geometric.hpp>
#include <glm/mat3x3.hpp>
#include <limits>

#include "arlight/common/image.hpp"
#include "arlight/common/response.hpp"

namespace arlight::render {

namespace {

// Running solid-angle (or texel) weighted sums of l alpha beta and its square.
struct LabSums {
  glm::dvec3 sum{0.0}, sum2{0.0};
  double weight = 0.0;
  void add(glm::vec3 rgb, double w) {
    const glm::dvec3 lab = glm::dmat3(lab_from_rgb()) * glm::dvec3(rgb);
    sum += w * lab, sum2 += w * lab * lab, weight += w;
  }
  ColourStats stats() const {
    ColourStats s;
    if (!(weight > 0.0)) return s;
    const glm::dvec3 mean = sum / weight;
    s.mean = glm::vec3(mean);
    s.sd = glm::vec3(glm::sqrt(glm::max(sum2 / weight - mean * mean, glm::dvec3(0.0))));
    return s;
  }
};

}  // namespace

glm::mat3 lab_from_rgb() {
  // Rows: l, alpha, beta (glm is column-major: built transposed).
  return glm::transpose(glm::mat3(0.3475f, 0.8231f, 0.5559f,   //
                                  0.2162f, 0.4316f, -0.6411f,  //
                                  0.1304f, -0.1033f, -0.0269f));
}

glm::mat3 rgb_from_lab() { return glm::inverse(lab_from_rgb()); }

EnvironmentPriors environment_priors(const EnvMap& radiance) {
  const EnvLayout& layout = radiance.layout;
  LabSums sides;
  std::array<double, 4> grey{}, weight{};  // -Z, +X, +Z, -X
  for (int y = 0; y < layout.height(); ++y)
    for (int x = 0; x < layout.width(); ++x) {
      const double w = layout.texel_solid_angle(x, y);
      if (!(w > 0.0)) continue;
      const glm::dvec3 d = layout.texel_dir(x, y);
      if (std::abs(d.y) > std::max(std::abs(d.x), std::abs(d.z))) continue;  // top or bottom
      const glm::vec3 c = radiance.image.at(x, y);
      sides.add(c, w);
      const int side = std::abs(d.z) >= std::abs(d.x) ? (d.z < 0 ? 0 : 2) : (d.x > 0 ? 1 : 3);
      grey[std::size_t(side)] += w * luminance(c), weight[std::size_t(side)] += w;
    }
  EnvironmentPriors p;
  p.lab = sides.stats();
  double total = 0.0, total_weight = 0.0;
  p.grey_low = std::numeric_limits<float>::max();
  for (std::size_t i = 0; i < 4; ++i) {
    if (!(weight[i] > 0.0)) continue;
    const float mean = float(grey[i] / weight[i]);
    p.grey_low = std::min(p.grey_low, mean), p.grey_high = std::max(p.grey_high, mean);
    total += grey[i], total_weight += weight[i];
  }
  if (!(total_weight > 0.0)) return EnvironmentPriors{};
  p.grey_mean = float(total / total_weight);
  return p;
}

std::vector<std::uint8_t> uv_coverage(const Mesh& mesh, int width, int height) {
  if (mesh.uvs.empty() || width < 1 || height < 1) return {};
  std::vector<std::uint8_t> covered(std::size_t(width) * height, 0);
  for_each_uv_texel(mesh, width, height, [&](int x, int y, std::size_t, const glm::dvec3&) {
    covered[std::size_t(y) * width + x] = 1;
  });
  return covered;
}

std::optional<ColourStats> model_priors(const Mesh& mesh, const Material& material) {
  const TextureImage* albedo = material.albedo.get();
  if (!albedo || mesh.uvs.empty())
    return ColourStats{lab_from_rgb() * material.kd, glm::vec3(0.0f)};
  const std::vector<std::uint8_t> covered = uv_coverage(mesh, albedo->width, albedo->height);
  LabSums sums;
  const CameraResponse srgb = CameraResponse::srgb();  // an 8-bit sRGB texel's linear value
  const int n = albedo->channels;
  for (std::size_t i = 0; i < covered.size(); ++i) {
    if (!covered[i]) continue;
    glm::vec3 c;
    for (int k = 0; k < 3; ++k) {
      const std::size_t at = i * std::size_t(n) + std::size_t(n == 1 ? 0 : k);
      c[k] = albedo->f32.empty()
                 ? (albedo->srgb ? srgb.linear(albedo->u8[at], 0) : float(albedo->u8[at]) / 255.0f)
                 : albedo->f32[at];
    }
    sums.add(material.kd * c, 1.0);
  }
  if (!(sums.weight > 0.0)) return std::nullopt;
  return sums.stats();
}

const char* colour_correction_name(ColourCorrection c) {
  switch (c) {
    case ColourCorrection::None:
      return "none";
    case ColourCorrection::Brightness:
      return "brightness";
    case ColourCorrection::Contrast:
      return "contrast";
    case ColourCorrection::Match:
      return "match";
  }
  return "?";
}

std::optional<ColourCorrection> colour_correction_named(std::string_view name) {
  for (ColourCorrection c : {ColourCorrection::None, ColourCorrection::Brightness,
                             ColourCorrection::Contrast, ColourCorrection::Match})
    if (name == colour_correction_name(c)) return c;
  return std::nullopt;
}

}  // namespace arlight::render
