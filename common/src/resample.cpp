#include "arlight/common/resample.hpp"

#include <algorithm>
#include <cmath>
#include <optional>

#include "parallel.hpp"

namespace arlight {

namespace {

// Solid angle of every texel of a layout, 0 off the sphere (scattered from the cached table).
std::vector<float> solid_angles(const EnvLayout& layout) {
  const auto table = texel_table(layout);
  std::vector<float> omega(layout.texel_count(), 0.0f);
  for (std::size_t i = 0; i < table->size(); ++i)
    omega[table->index[i]] = float(table->solid_angle[i]);
  return omega;
}

}  // namespace

EnvSampler::EnvSampler(const EnvMap& env) : layout_(env.layout) {
  levels_.push_back({env.image.width(), env.image.height(), env.image, solid_angles(env.layout)});
  const bool cube = layout_.projection() == Projection::Cube;
  while (true) {
    const Level& prev = levels_.back();
    if (prev.width == 1 && (cube || prev.height == 1)) break;
    Level next;
    if (!cube) {
      next.image = downsample2x(prev.image.view(), prev.weight.data(), &next.weight);
      next.width = next.image.width(), next.height = next.image.height();
    } else {
      const int n = prev.width, n2 = std::max(1, (n + 1) / 2);
      next.width = n2, next.height = 6 * n2;
      next.image = Image(n2, 6 * n2);
      next.weight.assign(std::size_t(n2) * 6 * n2, 0.0f);
      for (int f = 0; f < 6; ++f) {
        std::vector<float> fw;
        const Image face = downsample2x(prev.image.view().sub(0, f * n, n, n),
                                        prev.weight.data() + std::size_t(f) * n * n, &fw);
        for (int y = 0; y < n2; ++y)
          for (int x = 0; x < n2; ++x) {
            next.image.set(x, f * n2 + y, face.at(x, y));
            next.weight[std::size_t(f * n2 + y) * n2 + x] = fw[std::size_t(y) * n2 + x];
          }
      }
    }
    levels_.push_back(std::move(next));
  }
}

glm::vec3 EnvSampler::sample_level(const Level& lv, glm::dvec2 uv, int face) const {
  // Bilinear over the texels that lie on the sphere; lat-long wraps around in u, a cube map
  // clamps to the face the direction falls on.
  const double px = uv.x * lv.width - 0.5, py = uv.y * lv.height - 0.5;
  const int x0 = int(std::floor(px)), y0 = int(std::floor(py));
  const double tx = px - x0, ty = py - y0;
  int ymin = 0, ymax = lv.height - 1;
  if (face >= 0) ymin = face * lv.width, ymax = ymin + lv.width - 1;
  const bool wrap = layout_.projection() == Projection::LatLong;
  glm::dvec3 acc(0.0);
  double wsum = 0.0;
  for (int j = 0; j < 2; ++j) {
    const int y = std::clamp(y0 + j, ymin, ymax);
    const double wy = j ? ty : 1.0 - ty;
    for (int i = 0; i < 2; ++i) {
      int x = x0 + i;
      x = wrap ? ((x % lv.width) + lv.width) % lv.width : std::clamp(x, 0, lv.width - 1);
      const double w = wy * (i ? tx : 1.0 - tx);
      if (w <= 0.0 || lv.weight[std::size_t(y) * lv.width + x] <= 0.0f) continue;
      acc += w * glm::dvec3(lv.image.at(x, y));
      wsum += w;
    }
  }
  if (wsum > 0.0) return glm::vec3(acc / wsum);
  // Every tap is off the sphere (the very rim of an angle map): nearest texel on the sphere.
  const int x = std::clamp(int(uv.x * lv.width), 0, lv.width - 1);
  const int y = std::clamp(int(uv.y * lv.height), ymin, ymax);
  return lv.image.at(x, y);
}

glm::vec3 EnvSampler::sample(glm::dvec3 dir, double level) const {
  const glm::dvec2 uv = layout_.dir_to_uv(dir);
  const int face =
      layout_.projection() == Projection::Cube ? EnvLayout::cube_face_of_direction(dir) : -1;
  level = std::clamp(level, 0.0, double(levels_.size() - 1));
  const int l0 = int(std::floor(level));
  const double f = level - l0;
  const glm::vec3 a = sample_level(levels_[std::size_t(l0)], uv, face);
  if (f <= 0.0 || l0 + 1 >= int(levels_.size())) return a;
  const glm::vec3 b = sample_level(levels_[std::size_t(l0 + 1)], uv, face);
  return a * float(1.0 - f) + b * float(f);
}

double EnvSampler::texel_solid_angle_at(glm::dvec3 dir) const {
  const glm::ivec2 t = layout_.dir_to_texel(dir);
  return levels_[0].weight[std::size_t(t.y) * levels_[0].width + t.x];
}

EnvMap resample(const EnvMap& src, const EnvLayout& dst) {
  const EnvSampler sampler(src);
  const std::vector<float> dst_omega = solid_angles(dst);
  EnvMap out(dst);
  detail::parallel_for(0, dst.height(), [&](int y) {
    for (int x = 0; x < dst.width(); ++x) {
      const double omega = dst_omega[std::size_t(y) * dst.width() + x];
      if (omega <= 0.0) continue;
      const glm::dvec3 centre = dst.texel_dir(x, y);
      const double src_omega = std::max(1e-30, sampler.texel_solid_angle_at(centre));
      // Footprint of a destination texel in source texels (linear), split between n x n
      // sub-samples and the MIP level each sub-sample reads.
      const double ratio = std::sqrt(omega / src_omega);
      const int n = std::clamp(int(std::ceil(ratio - 1e-9)), 1, 4);
      const double level = std::max(0.0, std::log2(ratio / n));
      glm::dvec3 acc(0.0);
      int count = 0;
      for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
          const glm::dvec2 uv = dst.pixel_to_uv({x + (i + 0.5) / n, y + (j + 0.5) / n});
          if (!dst.uv_on_sphere(uv)) continue;
          acc += glm::dvec3(sampler.sample(dst.uv_to_dir(uv), level));
          ++count;
        }
      const glm::vec3 v = count ? glm::vec3(acc / double(count)) : sampler.sample(centre, level);
      out.image.set(x, y, v);
    }
  });
  return out;
}

namespace {

// Every texel of `src` added, by the texel its centre falls in, into the mean of `dst`'s
// texel; nothing when some texel of `dst` would get no source texel (dst too fine for src).
std::optional<EnvMap> bin_texels(const EnvMap& src, const EnvLayout& dst) {
  const auto from = texel_table(src.layout);
  const auto to = texel_table(dst);
  if (from->size() < 2 * to->size()) return std::nullopt;
  std::vector<double> sums(4 * dst.texel_count(), 0.0);
  const float* in = src.image.data();
  for (std::size_t i = 0; i < from->size(); ++i) {
    const glm::ivec2 t = dst.dir_to_texel({from->x[i], from->y[i], from->z[i]});
    double* s = sums.data() + 4 * (std::size_t(t.y) * std::size_t(dst.width()) + std::size_t(t.x));
    const double w = from->solid_angle[i];
    const float* p = in + 3 * std::size_t(from->index[i]);
    s[0] += w * p[0], s[1] += w * p[1], s[2] += w * p[2], s[3] += w;
  }
  EnvMap out(dst);
  float* o = out.image.data();
  for (std::uint32_t px : to->index) {
    const double* s = sums.data() + 4 * std::size_t(px);
    if (s[3] <= 0.0) return std::nullopt;
    for (int c = 0; c < 3; ++c) o[3 * std::size_t(px) + std::size_t(c)] = float(s[c] / s[3]);
  }
  return out;
}

}  // namespace

EnvMap reduce(const EnvMap& src, const EnvLayout& dst) {
  const EnvLayout& from = src.layout;
  if (from.projection() != Projection::Cube || dst.projection() != Projection::Cube ||
      dst.face_size() > from.face_size() || from.face_size() % dst.face_size() != 0) {
    if (auto binned = bin_texels(src, dst)) return std::move(*binned);
    return resample(src, dst);
  }
  const int k = from.face_size() / dst.face_size();
  const auto table = texel_table(from);  // every texel of a cube map is on the sphere
  std::vector<double> omega(from.texel_count(), 0.0);
  for (std::size_t i = 0; i < table->size(); ++i) omega[table->index[i]] = table->solid_angle[i];
  EnvMap out(dst);
  const float* in = src.image.data();
  float* o = out.image.data();
  const std::size_t w = std::size_t(from.width());
  for (int y = 0; y < dst.height(); ++y)
    for (int x = 0; x < dst.width(); ++x) {
      double sum[3] = {0.0, 0.0, 0.0}, weight = 0.0;
      for (int j = 0; j < k; ++j)
        for (int i = 0; i < k; ++i) {
          const std::size_t p = std::size_t(y * k + j) * w + std::size_t(x * k + i);
          for (int c = 0; c < 3; ++c) sum[c] += omega[p] * in[3 * p + std::size_t(c)];
          weight += omega[p];
        }
      float* t = o + 3 * (std::size_t(y) * std::size_t(dst.width()) + std::size_t(x));
      for (int c = 0; c < 3; ++c) t[c] = weight > 0.0 ? float(sum[c] / weight) : 0.0f;
    }
  return out;
}

}  // namespace arlight
