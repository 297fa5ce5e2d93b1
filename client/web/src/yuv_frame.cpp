#include "yuv_frame.hpp"

#include <glm/gtc/type_ptr.hpp>
#include <glm/mat3x3.hpp>
#include <stdexcept>

namespace arlight::web {

YuvLayout yuv_layout_named(const std::string& name) {
  if (name == "NV12") return YuvLayout::Nv12;
  if (name == "I420") return YuvLayout::I420;
  throw std::invalid_argument("frame layout '" + name + "': NV12 or I420");
}

namespace {

// Y'CbCr -> R'G'B' for the luma weights (Kr, Kb) of a matrix (ITU-R BT.601, BT.709, BT.2020;
// the names are WebCodecs' VideoColorSpace.matrix values).
glm::mat3 from_ycbcr(const std::string& matrix) {
  double kr, kb;
  if (matrix == "bt709") {
    kr = 0.2126, kb = 0.0722;
  } else if (matrix == "smpte170m" || matrix == "bt470bg") {
    kr = 0.299, kb = 0.114;
  } else if (matrix == "bt2020-ncl") {
    kr = 0.2627, kb = 0.0593;
  } else {
    throw std::invalid_argument("colour matrix '" + matrix + "': bt709, smpte170m, bt470bg or bt2020-ncl");
  }
  const double kg = 1.0 - kr - kb;
  // Columns: the contribution of Y', Cb, Cr to (R', G', B').
  return glm::mat3(glm::vec3(1.0f),
                   glm::vec3(0.0f, float(-2.0 * kb * (1.0 - kb) / kg), float(2.0 * (1.0 - kb))),
                   glm::vec3(float(2.0 * (1.0 - kr)), float(-2.0 * kr * (1.0 - kr) / kg), 0.0f));
}

}  // namespace

YuvFrame::YuvFrame(int width, int height, const std::filesystem::path& shader_dir)
    : width_(width),
      height_(height),
      nv12_(shader_dir, "fullscreen.vert", "yuv_to_rgb.frag", {{"PLANAR", "0"}}),
      i420_(shader_dir, "fullscreen.vert", "yuv_to_rgb.frag", {{"PLANAR", "1"}}) {
  if (width < 2 || height < 2 || width % 2 || height % 2)
    throw std::invalid_argument("a YUV 4:2:0 frame needs an even size");
  framebuffer_.create();
  glGenVertexArrays(1, &vertex_array_);
}

YuvFrame::~YuvFrame() {
  if (vertex_array_) glDeleteVertexArrays(1, &vertex_array_);
}

void YuvFrame::make_planes(YuvLayout layout) {
  if (planes_layout_ == layout) return;
  const int cw = width_ / 2, ch = height_ / 2;
  const struct {
    GLenum internal;
    int w, h;
  } planes[3] = {{GL_R8, width_, height_},
                 {layout == YuvLayout::Nv12 ? GLenum(GL_RG8) : GLenum(GL_R8), cw, ch},
                 {GL_R8, cw, ch}};
  for (int i = 0; i < 3; ++i) {
    planes_[std::size_t(i)] = render::gl::Texture();
    if (i == 2 && layout == YuvLayout::Nv12) continue;
    planes_[std::size_t(i)].create();
    glBindTexture(GL_TEXTURE_2D, planes_[std::size_t(i)].id);
    glTexStorage2D(GL_TEXTURE_2D, 1, planes[i].internal, planes[i].w, planes[i].h);
    render::gl::set_sampling(GL_TEXTURE_2D, i == 0 ? GL_NEAREST : GL_LINEAR, GL_CLAMP_TO_EDGE,
                             GL_CLAMP_TO_EDGE);
  }
  glBindTexture(GL_TEXTURE_2D, 0);
  planes_layout_ = layout;
}

unsigned YuvFrame::plane_texture(YuvLayout layout, int plane) {
  if (plane < 0 || plane > (layout == YuvLayout::Nv12 ? 1 : 2))
    throw std::invalid_argument("no plane " + std::to_string(plane) + " in this layout");
  make_planes(layout);
  return planes_[std::size_t(plane)].id;
}

void YuvFrame::convert(YuvLayout layout, const std::string& matrix, bool full_range,
                       unsigned target) {
  const glm::mat3 m = from_ycbcr(matrix);
  make_planes(layout);
  // Limited range: Y' in [16, 235], Cb and Cr in [16, 240] (8-bit codes), stretched to [0, 1]
  // and [-0.5, 0.5] by scaling the matrix.
  const float y_scale = full_range ? 1.0f : 255.0f / 219.0f, c_scale = full_range ? 1.0f : 255.0f / 224.0f;
  const glm::mat3 scaled = m * glm::mat3(glm::vec3(y_scale, 0, 0), glm::vec3(0, c_scale, 0),
                                         glm::vec3(0, 0, c_scale));
  const glm::vec3 offset(full_range ? 0.0f : 16.0f / 255.0f, 128.0f / 255.0f, 128.0f / 255.0f);

  glBindFramebuffer(GL_FRAMEBUFFER, framebuffer_.id);
  if (attached_ != target) {
    glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, target, 0);
    render::gl::check_framebuffer("the camera texture (YUV conversion)");
    attached_ = target;
  }
  const render::Program& p = layout == YuvLayout::Nv12 ? nv12_ : i420_;
  glUseProgram(p.id());
  const int planes = layout == YuvLayout::Nv12 ? 2 : 3;
  const char* samplers[3] = {"u_luma", "u_chroma_u", "u_chroma_v"};
  for (int i = 0; i < planes; ++i) {
    glActiveTexture(GLenum(GL_TEXTURE0 + i));
    glBindTexture(GL_TEXTURE_2D, planes_[std::size_t(i)].id);
    glUniform1i(p.uniform(samplers[i]), i);
  }
  glUniformMatrix3fv(p.uniform("u_from_ycbcr"), 1, GL_FALSE, glm::value_ptr(scaled));
  glUniform3fv(p.uniform("u_offset"), 1, glm::value_ptr(offset));
  glViewport(0, 0, width_, height_);
  glDisable(GL_DEPTH_TEST);
  glDisable(GL_BLEND);
  glDisable(GL_CULL_FACE);
  glBindVertexArray(vertex_array_);
  glDrawArrays(GL_TRIANGLES, 0, 3);
  glBindVertexArray(0);
  for (int i = planes - 1; i >= 0; --i) {
    glActiveTexture(GLenum(GL_TEXTURE0 + i));
    glBindTexture(GL_TEXTURE_2D, 0);
  }
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
  render::gl::check("YUV conversion");
}

}  // namespace arlight::web
