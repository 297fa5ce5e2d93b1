// The camera frame's planes into the renderer's camera texture, for browsers where copying a
// VideoFrame's planes out (WebCodecs copyTo) and converting them on the GPU is faster than
// uploading the <video> (headless Chromium on SwiftShader: ~5 ms against ~30 ms at 640x480; a
// phone's GPU takes the <video> without a copy, and the page measures both and keeps the faster).
// The page uploads the planes into plane_texture(i) with texSubImage2D (no copy through the
// module's memory), then convert() draws yuv_to_rgb.frag into the target texture.
#pragma once

#include <array>
#include <filesystem>
#include <optional>
#include <string>

#include "arlight/render/shader.hpp"
#include "gl.hpp"

namespace arlight::web {

enum class YuvLayout { Nv12, I420 };
// "NV12" or "I420" (WebCodecs' names); std::invalid_argument for another.
YuvLayout yuv_layout_named(const std::string& name);

class YuvFrame {
 public:
  // The frame's size (even); shaders from `shader_dir`. Needs the current GL context.
  YuvFrame(int width, int height, const std::filesystem::path& shader_dir);
  ~YuvFrame();
  YuvFrame(const YuvFrame&) = delete;
  YuvFrame& operator=(const YuvFrame&) = delete;

  // Textures for the planes of `layout`: 0 luma (R8, full size), 1 chroma (NV12: RG8 Cb/Cr; I420:
  // R8 Cb), 2 (I420: R8 Cr) at half size. Throws std::invalid_argument for another plane.
  unsigned plane_texture(YuvLayout layout, int plane);

  // Converts the uploaded planes into `target` (an RGB8 texture of the frame's size) with the
  // frame's colour matrix ("bt709", "smpte170m" / "bt470bg" (BT.601), "bt2020-ncl") and range.
  // Throws std::invalid_argument for another matrix.
  void convert(YuvLayout layout, const std::string& matrix, bool full_range, unsigned target);

 private:
  void make_planes(YuvLayout layout);

  int width_, height_;
  render::Program nv12_, i420_;
  std::array<render::gl::Texture, 3> planes_;
  std::optional<YuvLayout> planes_layout_;  // what planes_ were made for
  render::gl::Framebuffer framebuffer_;
  unsigned attached_ = 0;  // the target texture framebuffer_ draws into
  GLuint vertex_array_ = 0;
};

}  // namespace arlight::web
