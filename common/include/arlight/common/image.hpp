// Float RGB images, non-owning views, bilinear sampling and area-correct 2x downsampling.
#pragma once

#include <cstddef>
#include <glm/vec3.hpp>
#include <vector>

namespace arlight {

// Relative luminance of linear Rec. 709 / sRGB primaries (ITU-R BT.709), of a colour (glm::vec3
// or dvec3, in its own precision) or of three channels of anything that scales by a double.
template <class Vec3>
constexpr auto luminance(const Vec3& rgb) {
  using T = decltype(rgb.x);
  return T(0.2126) * rgb.x + T(0.7152) * rgb.y + T(0.0722) * rgb.z;
}
template <class T>
constexpr T luminance(const T& r, const T& g, const T& b) {
  return 0.2126 * r + 0.7152 * g + 0.0722 * b;
}

// How a sampler treats coordinates outside the image along one axis.
enum class Edge { Clamp, Wrap };

// A read-only window on interleaved RGB float pixels. `stride` is in floats per row, so a view
// can address a sub-rectangle (a tile, a cube face) of a larger image without copying.
struct ConstImageView {
  const float* data = nullptr;
  int width = 0;
  int height = 0;
  std::ptrdiff_t stride = 0;

  const float* pixel(int x, int y) const { return data + y * stride + 3 * std::ptrdiff_t(x); }
  glm::vec3 at(int x, int y) const {
    const float* p = pixel(x, y);
    return {p[0], p[1], p[2]};
  }
  ConstImageView sub(int x, int y, int w, int h) const;  // throws std::out_of_range
};

struct ImageView {
  float* data = nullptr;
  int width = 0;
  int height = 0;
  std::ptrdiff_t stride = 0;

  float* pixel(int x, int y) const { return data + y * stride + 3 * std::ptrdiff_t(x); }
  glm::vec3 at(int x, int y) const { return ConstImageView(*this).at(x, y); }
  void set(int x, int y, glm::vec3 v) const {
    float* p = pixel(x, y);
    p[0] = v.x, p[1] = v.y, p[2] = v.z;
  }
  ImageView sub(int x, int y, int w, int h) const;  // throws std::out_of_range
  operator ConstImageView() const { return {data, width, height, stride}; }
};

// An owning, contiguous RGB float image; row 0 is the top row, as stored in image files.
class Image {
 public:
  Image() = default;
  Image(int width, int height, glm::vec3 fill = glm::vec3(0.0f));  // throws std::invalid_argument

  int width() const { return width_; }
  int height() const { return height_; }
  bool empty() const { return width_ == 0 || height_ == 0; }
  std::size_t texel_count() const { return std::size_t(width_) * std::size_t(height_); }

  float* data() { return data_.data(); }
  const float* data() const { return data_.data(); }
  std::vector<float>& storage() { return data_; }
  const std::vector<float>& storage() const { return data_; }

  glm::vec3 at(int x, int y) const { return view().at(x, y); }
  void set(int x, int y, glm::vec3 v) { view().set(x, y, v); }

  ImageView view() { return {data_.data(), width_, height_, 3 * std::ptrdiff_t(width_)}; }
  ConstImageView view() const {
    return {data_.data(), width_, height_, 3 * std::ptrdiff_t(width_)};
  }

 private:
  int width_ = 0;
  int height_ = 0;
  std::vector<float> data_;
};

// Copies a view into a new contiguous image.
Image copy_image(ConstImageView src);

// Bilinear sample at continuous pixel coordinates (px, py); texel (i, j) has its centre at
// (i + 0.5, j + 0.5). Outside the image each axis clamps or wraps as asked.
glm::vec3 sample_bilinear(ConstImageView img, double px, double py, Edge edge_x = Edge::Clamp,
                          Edge edge_y = Edge::Clamp);

// Area-correct 2x reduction: output texel (i, j) is the exact area-weighted mean of the input
// region it covers. Even sizes halve (a 2x2 box); odd sizes become ceil(n/2) texels that each
// cover n/ceil(n/2) input texels, with fractional weights at the shared borders, so no input
// texel is dropped or counted twice. A 1-texel axis stays 1.
//
// `weights` (optional, one float per texel, same layout as `src` without channels) turns this
// into a weighted mean (e.g. solid angle, validity); the summed weight of every output texel is
// then written to `out_weights` if given. Texels whose weights sum to zero become 0.
Image downsample2x(ConstImageView src, const float* weights = nullptr,
                   std::vector<float>* out_weights = nullptr);

// Level 0 is the input; each further level is downsample2x of the one before, down to 1x1.
std::vector<Image> build_mip_pyramid(const Image& base);

}  // namespace arlight
