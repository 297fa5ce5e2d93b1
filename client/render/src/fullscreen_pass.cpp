#include "fullscreen_pass.hpp"

namespace arlight::render {

FullscreenPass::FullscreenPass() { glGenVertexArrays(1, &vao_); }

FullscreenPass::~FullscreenPass() {
  if (vao_) glDeleteVertexArrays(1, &vao_);
}

void FullscreenPass::draw(GLenum mode, GLsizei count) const {
  glBindVertexArray(vao_);
  glDrawArrays(mode, 0, count);
  glBindVertexArray(0);
}

void make_target_texture(gl::Texture& tex, GLenum internal, GLenum format, GLenum type, int w,
                         int h) {
  tex.create();
  glBindTexture(GL_TEXTURE_2D, tex.id);
  glTexImage2D(GL_TEXTURE_2D, 0, GLint(internal), w, h, 0, format, type, nullptr);
  gl::set_sampling(GL_TEXTURE_2D, GL_NEAREST, GL_CLAMP_TO_EDGE, GL_CLAMP_TO_EDGE);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAX_LEVEL, 0);
}

RenderTargets::RenderTargets(int width, int height) : w(width), h(height) {
  // HDR target: RGBA16F radiance + R8 mask + depth. Only the mask and depth are cleared each
  // frame (llvmpipe clears float targets slowly); radiance is read only where the mask is set.
  make_target_texture(hdr_tex, GL_RGBA16F, GL_RGBA, GL_HALF_FLOAT, w, h);
  make_target_texture(mask_tex, GL_R8, GL_RED, GL_UNSIGNED_BYTE, w, h);
  depth.create();
  glBindRenderbuffer(GL_RENDERBUFFER, depth.id);
  glRenderbufferStorage(GL_RENDERBUFFER, GL_DEPTH_COMPONENT24, w, h);
  hdr_fbo.create();
  glBindFramebuffer(GL_FRAMEBUFFER, hdr_fbo.id);
  glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, hdr_tex.id, 0);
  glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT1, GL_TEXTURE_2D, mask_tex.id, 0);
  glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, depth.id);
  const GLenum both[2] = {GL_COLOR_ATTACHMENT0, GL_COLOR_ATTACHMENT1};
  glDrawBuffers(2, both);
  gl::check_framebuffer("HDR target (RGBA16F + R8 mask + depth)");

  // The output: the camera frame's BGR bytes are uploaded straight into it (RGB8 holding B, G,
  // R), and the composite pass overwrites only the virtual pixels: it shares the HDR depth
  // buffer and draws at the far plane with GL_GREATER, so only pixels with geometry pass.
  make_target_texture(out_tex, GL_RGB8, GL_RGB, GL_UNSIGNED_BYTE, w, h);
  out_fbo.create();
  glBindFramebuffer(GL_FRAMEBUFFER, out_fbo.id);
  glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, out_tex.id, 0);
  glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, depth.id);
  gl::check_framebuffer("composite target (RGB8 + the HDR depth)");
}

}  // namespace arlight::render
