// 8-bit interleaved images (1, 3 or 4 channels, rows top to bottom): camera frames and texture
// images as they cross library boundaries, without OpenCV (the renderer's core also builds for
// WebAssembly). The channel order is the producer's and is named where an image is taken: camera
// frames are BGR (OpenCV's order, what the sources deliver), textures RGB(A).
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace arlight {

// A read-only window on 8-bit pixels; `stride` is bytes per row (>= width * channels).
struct ImageU8View {
  const std::uint8_t* data = nullptr;
  int width = 0, height = 0, channels = 0;
  std::ptrdiff_t stride = 0;

  const std::uint8_t* row(int y) const { return data + y * stride; }
  bool packed() const { return stride == std::ptrdiff_t(width) * channels; }
};

// Owns packed 8-bit pixels.
class ImageU8 {
 public:
  ImageU8() = default;
  ImageU8(int width, int height, int channels)
      : width_(width),
        height_(height),
        channels_(channels),
        pixels_(std::size_t(width) * std::size_t(height) * std::size_t(channels)) {}
  int width() const { return width_; }
  int height() const { return height_; }
  int channels() const { return channels_; }
  bool empty() const { return pixels_.empty(); }
  std::uint8_t* data() { return pixels_.data(); }
  const std::uint8_t* data() const { return pixels_.data(); }
  std::uint8_t* row(int y) { return pixels_.data() + std::size_t(y) * width_ * channels_; }
  ImageU8View view() const {
    return {pixels_.data(), width_, height_, channels_, std::ptrdiff_t(width_) * channels_};
  }
  // Reshapes (reallocating only when it grows); the pixels are then undefined.
  void resize(int width, int height, int channels) {
    width_ = width, height_ = height, channels_ = channels;
    pixels_.resize(std::size_t(width) * std::size_t(height) * std::size_t(channels));
  }

 private:
  int width_ = 0, height_ = 0, channels_ = 0;
  std::vector<std::uint8_t> pixels_;
};

}  // namespace arlight
