// Internal: the GLES 3 headers and small helpers shared by the renderer's sources.
#pragma once

#include <GLES3/gl3.h>

#include <string>

#include "arlight/render/gl_context.hpp"

namespace arlight::render::gl {

// Throws GlError("<what>: GL error 0x....") if glGetError() reports one.
void check(const char* what);

// Owns a texture / framebuffer / renderbuffer name.
struct Texture {
  GLuint id = 0;
  Texture() = default;
  Texture(Texture&& o) noexcept : id(o.id) { o.id = 0; }
  Texture& operator=(Texture&& o) noexcept {
    std::swap(id, o.id);
    return *this;
  }
  ~Texture() {
    if (id) glDeleteTextures(1, &id);
  }
  void create() {
    if (!id) glGenTextures(1, &id);
  }
};

struct Framebuffer {
  GLuint id = 0;
  Framebuffer() = default;
  Framebuffer(Framebuffer&& o) noexcept : id(o.id) { o.id = 0; }
  ~Framebuffer() {
    if (id) glDeleteFramebuffers(1, &id);
  }
  void create() {
    if (!id) glGenFramebuffers(1, &id);
  }
};

struct Renderbuffer {
  GLuint id = 0;
  ~Renderbuffer() {
    if (id) glDeleteRenderbuffers(1, &id);
  }
  void create() {
    if (!id) glGenRenderbuffers(1, &id);
  }
};

// Sets min/mag filter and wrap modes of the texture bound to `target`.
void set_sampling(GLenum target, GLenum filter, GLenum wrap_s, GLenum wrap_t);
// Checks glCheckFramebufferStatus of the bound draw framebuffer; `what` names it.
void check_framebuffer(const char* what);

}  // namespace arlight::render::gl
