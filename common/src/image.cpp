#include "arlight/common/image.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace arlight {

namespace {

void check_sub(int x, int y, int w, int h, int width, int height) {
  if (x < 0 || y < 0 || w < 0 || h < 0 || x + w > width || y + h > height)
    throw std::out_of_range("image sub-view " + std::to_string(w) + "x" + std::to_string(h) + "+" +
                            std::to_string(x) + "+" + std::to_string(y) + " lies outside a " +
                            std::to_string(width) + "x" + std::to_string(height) + " image");
}

int wrap_or_clamp(int i, int n, Edge edge) {
  if (edge == Edge::Wrap) {
    i %= n;
    return i < 0 ? i + n : i;
  }
  return std::clamp(i, 0, n - 1);
}

// For an axis of n input texels reduced to m output texels (m = ceil(n/2)), output texel o
// covers input interval [o*n/m, (o+1)*n/m). Lists the input texels it overlaps with their
// overlap lengths (in input texels).
struct Tap {
  int index;
  double weight;
};

std::vector<std::vector<Tap>> area_taps(int n, int m) {
  std::vector<std::vector<Tap>> taps(m);
  const double scale = double(n) / double(m);
  for (int o = 0; o < m; ++o) {
    const double lo = o * scale, hi = (o + 1) * scale;
    for (int i = int(std::floor(lo)); i < n && i < hi; ++i) {
      const double w = std::min(hi, double(i + 1)) - std::max(lo, double(i));
      if (w > 1e-12) taps[o].push_back({i, w});
    }
  }
  return taps;
}

}  // namespace

ConstImageView ConstImageView::sub(int x, int y, int w, int h) const {
  check_sub(x, y, w, h, width, height);
  return {pixel(x, y), w, h, stride};
}

ImageView ImageView::sub(int x, int y, int w, int h) const {
  check_sub(x, y, w, h, width, height);
  return {pixel(x, y), w, h, stride};
}

Image::Image(int width, int height, glm::vec3 fill) : width_(width), height_(height) {
  if (width < 0 || height < 0)
    throw std::invalid_argument("image size must not be negative, got " + std::to_string(width) +
                                "x" + std::to_string(height));
  data_.resize(texel_count() * 3);
  for (std::size_t i = 0; i < texel_count(); ++i) {
    data_[3 * i] = fill.x;
    data_[3 * i + 1] = fill.y;
    data_[3 * i + 2] = fill.z;
  }
}

Image copy_image(ConstImageView src) {
  Image out(src.width, src.height);
  for (int y = 0; y < src.height; ++y)
    std::copy_n(src.pixel(0, y), 3 * std::size_t(src.width), out.view().pixel(0, y));
  return out;
}

glm::vec3 sample_bilinear(ConstImageView img, double px, double py, Edge edge_x, Edge edge_y) {
  const double fx = px - 0.5, fy = py - 0.5;
  const double x0f = std::floor(fx), y0f = std::floor(fy);
  const float tx = float(fx - x0f), ty = float(fy - y0f);
  const int x0 = wrap_or_clamp(int(x0f), img.width, edge_x);
  const int x1 = wrap_or_clamp(int(x0f) + 1, img.width, edge_x);
  const int y0 = wrap_or_clamp(int(y0f), img.height, edge_y);
  const int y1 = wrap_or_clamp(int(y0f) + 1, img.height, edge_y);
  const glm::vec3 top = img.at(x0, y0) * (1.0f - tx) + img.at(x1, y0) * tx;
  const glm::vec3 bottom = img.at(x0, y1) * (1.0f - tx) + img.at(x1, y1) * tx;
  return top * (1.0f - ty) + bottom * ty;
}

Image downsample2x(ConstImageView src, const float* weights, std::vector<float>* out_weights) {
  const int w = std::max(1, (src.width + 1) / 2), h = std::max(1, (src.height + 1) / 2);
  const auto tx = area_taps(src.width, w), ty = area_taps(src.height, h);
  Image out(w, h);
  if (out_weights) out_weights->assign(std::size_t(w) * h, 0.0f);
  for (int oy = 0; oy < h; ++oy) {
    for (int ox = 0; ox < w; ++ox) {
      double acc[3] = {0, 0, 0}, wsum = 0;
      for (const Tap& a : ty[oy]) {
        for (const Tap& b : tx[ox]) {
          double wt = a.weight * b.weight;
          if (weights) wt *= weights[std::size_t(a.index) * src.width + b.index];
          const float* p = src.pixel(b.index, a.index);
          acc[0] += wt * p[0], acc[1] += wt * p[1], acc[2] += wt * p[2];
          wsum += wt;
        }
      }
      const double inv = wsum > 0 ? 1.0 / wsum : 0.0;
      out.set(ox, oy, glm::vec3(acc[0] * inv, acc[1] * inv, acc[2] * inv));
      if (out_weights) (*out_weights)[std::size_t(oy) * w + ox] = float(wsum);
    }
  }
  return out;
}

std::vector<Image> build_mip_pyramid(const Image& base) {
  std::vector<Image> levels;
  levels.push_back(base);
  while (levels.back().width() > 1 || levels.back().height() > 1)
    levels.push_back(downsample2x(levels.back().view()));
  return levels;
}

}  // namespace arlight
