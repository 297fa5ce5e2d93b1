// GL helpers every part of the renderer uses, independent of how the context was made (EGL
// natively, WebGL2 in the browser).
#include "gl.hpp"

#include <cstdio>
#include <string>

namespace arlight::render {

// GlContext's queries of the current context, the same natively and in the browser.
std::string GlContext::renderer() const {
  const auto* s = glGetString(GL_RENDERER);
  return s ? reinterpret_cast<const char*>(s) : "";
}

std::string GlContext::version() const {
  const auto* s = glGetString(GL_VERSION);
  return s ? reinterpret_cast<const char*>(s) : "";
}

bool GlContext::has_extension(const std::string& name) const {
  GLint n = 0;
  glGetIntegerv(GL_NUM_EXTENSIONS, &n);
  for (GLint i = 0; i < n; ++i) {
    const auto* e = reinterpret_cast<const char*>(glGetStringi(GL_EXTENSIONS, GLuint(i)));
    if (e && name == e) return true;
  }
  return false;
}

namespace gl {

void check(const char* what) {
#ifdef __EMSCRIPTEN__
  // In a browser glGetError is a round trip to the GPU process that stalls the page: check the
  // first 256 calls (construction, shader variants, the first frames) and then every 64th.
  static unsigned calls = 0;
  if (++calls > 256 && calls % 64 != 0) return;
#endif
  const GLenum e = glGetError();
  if (e == GL_NO_ERROR) return;
  char buf[16];
  std::snprintf(buf, sizeof buf, "0x%04x", unsigned(e));
  throw GlError(std::string(what) + ": GL error " + buf);
}

void set_sampling(GLenum target, GLenum filter, GLenum wrap_s, GLenum wrap_t) {
  glTexParameteri(target, GL_TEXTURE_MIN_FILTER, GLint(filter));
  glTexParameteri(target, GL_TEXTURE_MAG_FILTER, GLint(filter));
  glTexParameteri(target, GL_TEXTURE_WRAP_S, GLint(wrap_s));
  glTexParameteri(target, GL_TEXTURE_WRAP_T, GLint(wrap_t));
}

void check_framebuffer(const char* what) {
  const GLenum s = glCheckFramebufferStatus(GL_DRAW_FRAMEBUFFER);
  if (s == GL_FRAMEBUFFER_COMPLETE) return;
  char buf[16];
  std::snprintf(buf, sizeof buf, "0x%04x", unsigned(s));
  throw GlError(std::string(what) + ": framebuffer incomplete (status " + buf + ")");
}

}  // namespace gl

}  // namespace arlight::render
