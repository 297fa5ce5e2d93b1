#include "y4m.hpp"

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "arlight/common/error.hpp"

namespace arlight::sim {

namespace {

constexpr double kKr = 0.2126, kKb = 0.0722, kKg = 1.0 - kKr - kKb;  // BT.709

std::uint8_t code(double v) { return std::uint8_t(std::clamp(std::lround(v), 0L, 255L)); }

}  // namespace

Y4mWriter::Y4mWriter(const std::filesystem::path& path, int width, int height, int fps)
    : path_(path), out_(path, std::ios::binary), width_(width), height_(height) {
  if (width < 2 || height < 2 || width % 2 || height % 2)
    throw InputError("--y4m: the frame size " + std::to_string(width) + "x" +
                     std::to_string(height) + " must be even (4:2:0 video)");
  if (fps < 1) throw InputError("--y4m: the frame rate must be at least 1");
  if (!out_) throw InputError("--y4m '" + path.string() + "': cannot write it");
  out_ << "YUV4MPEG2 W" << width << " H" << height << " F" << fps
       << ":1 Ip A1:1 C420jpeg XCOLORRANGE=LIMITED\n";
}

void Y4mWriter::add(const std::uint8_t* bgr, std::ptrdiff_t stride) {
  const int w = width_, h = height_;
  std::vector<std::uint8_t> y(std::size_t(w) * h), cb(std::size_t(w / 2) * (h / 2)), cr(cb.size());
  for (int row = 0; row < h; ++row) {
    const std::uint8_t* p = bgr + row * stride;
    for (int x = 0; x < w; ++x) {
      const double r = p[3 * x + 2] / 255.0, g = p[3 * x + 1] / 255.0, b = p[3 * x] / 255.0;
      y[std::size_t(row) * w + x] = code(16.0 + 219.0 * (kKr * r + kKg * g + kKb * b));
    }
  }
  // Chroma of each 2x2 block's mean colour (the encoded values, as a camera's ISP would).
  for (int by = 0; by < h / 2; ++by)
    for (int bx = 0; bx < w / 2; ++bx) {
      double r = 0, g = 0, b = 0;
      for (int dy = 0; dy < 2; ++dy) {
        const std::uint8_t* p = bgr + (2 * by + dy) * stride + 3 * 2 * bx;
        for (int dx = 0; dx < 2; ++dx) b += p[3 * dx], g += p[3 * dx + 1], r += p[3 * dx + 2];
      }
      r /= 4 * 255.0, g /= 4 * 255.0, b /= 4 * 255.0;
      const double luma = kKr * r + kKg * g + kKb * b;
      cb[std::size_t(by) * (w / 2) + bx] = code(128.0 + 224.0 * (b - luma) / (2 * (1 - kKb)));
      cr[std::size_t(by) * (w / 2) + bx] = code(128.0 + 224.0 * (r - luma) / (2 * (1 - kKr)));
    }
  out_ << "FRAME\n";
  out_.write(reinterpret_cast<const char*>(y.data()), std::streamsize(y.size()));
  out_.write(reinterpret_cast<const char*>(cb.data()), std::streamsize(cb.size()));
  out_.write(reinterpret_cast<const char*>(cr.data()), std::streamsize(cr.size()));
  if (!out_) throw InputError("--y4m '" + path_.string() + "': write failed (disk full?)");
}

}  // namespace arlight::sim
