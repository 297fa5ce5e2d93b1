// An OpenGL ES 3 context through EGL: headless (Mesa's surfaceless platform, rendering into
// framebuffer objects only) by default, or an X11 window when built with libx11 and $DISPLAY is
// set; in the browser build a WebGL2 context on a canvas. Every failure throws GlError naming
// the EGL/GL step that failed.
#pragma once

#include <memory>
#include <stdexcept>
#include <string>

namespace arlight::render {

// A GL or EGL failure (no display, no ES 3 config, missing extension, compile error, ...).
class GlError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class GlContext {
 public:
  // Headless: EGL_PLATFORM_SURFACELESS_MESA, an ES 3 context made current without a surface.
  static GlContext headless();
  // A window of width x height on the X11 display in $DISPLAY; throws GlError "no display"
  // when $DISPLAY is unset or the library was built without X11.
  static GlContext window(int width, int height, const std::string& title);
  // Whether window() can work in this build and environment (X11 built in, $DISPLAY set).
  static bool window_available();
  // The browser build (gl_context_web.cpp): a WebGL2 context on the page's canvas named by a
  // CSS selector ("#view"), with EXT_color_buffer_float enabled. Natively: GlError.
  static GlContext canvas(const std::string& selector);

  GlContext(GlContext&&) noexcept;
  GlContext& operator=(GlContext&&) noexcept;
  ~GlContext();

  void make_current();
  // Shows the default framebuffer (window contexts only; a no-op headless).
  void swap_buffers();
  bool has_window() const;

  std::string renderer() const;  // GL_RENDERER, e.g. "llvmpipe (LLVM 15.0.6, 256 bits)"
  std::string version() const;   // GL_VERSION
  bool has_extension(const std::string& name) const;  // e.g. "GL_EXT_color_buffer_float"

 private:
  struct State;
  explicit GlContext(std::unique_ptr<State> s);
  std::unique_ptr<State> s_;
};

}  // namespace arlight::render
