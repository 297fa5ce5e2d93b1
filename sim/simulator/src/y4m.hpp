// Internal: the simulated camera as a YUV4MPEG2 video, which Chromium's fake camera
// (--use-file-for-fake-video-capture) plays to a page as if it were a phone's camera.
#pragma once

#include <cstdint>
#include <filesystem>
#include <fstream>

namespace arlight::sim {

// 4:2:0, BT.709 limited range (Y 16-235, Cb/Cr 16-240): what Chromium 156 decodes the fake
// camera's samples as, whatever the header's C tag says (measured: tests/web/harness.mjs). The
// header is the one verified there: "YUV4MPEG2 W H F<fps>:1 Ip A1:1 C420jpeg
// XCOLORRANGE=LIMITED". Width and height must be even.
class Y4mWriter {
 public:
  Y4mWriter(const std::filesystem::path& path, int width, int height, int fps);
  // One frame of 8-bit BGR pixels (OpenCV's order), rows `stride` bytes apart, row 0 on top.
  void add(const std::uint8_t* bgr, std::ptrdiff_t stride);

 private:
  std::filesystem::path path_;
  std::ofstream out_;
  int width_, height_;
};

}  // namespace arlight::sim
