// GlContext in the browser (emscripten): a WebGL2 context on a canvas of the page. The renderer
// above it is the same code as natively; WebGL2 is GLES 3.0 with EXT_color_buffer_float for the
// renderer's RGBA16F targets.
#include <GLES3/gl3.h>
#include <emscripten/html5.h>

#include "arlight/render/gl_context.hpp"

namespace arlight::render {

struct GlContext::State {
  EMSCRIPTEN_WEBGL_CONTEXT_HANDLE context = 0;
  ~State() {
    if (context > 0) emscripten_webgl_destroy_context(context);
  }
};

GlContext::GlContext(std::unique_ptr<State> s) : s_(std::move(s)) {}
GlContext::GlContext(GlContext&&) noexcept = default;
GlContext& GlContext::operator=(GlContext&&) noexcept = default;
GlContext::~GlContext() = default;

GlContext GlContext::canvas(const std::string& selector) {
  EmscriptenWebGLContextAttributes a;
  emscripten_webgl_init_context_attributes(&a);
  a.majorVersion = 2;
  a.minorVersion = 0;
  a.alpha = false;
  a.depth = true;
  a.antialias = false;
  a.premultipliedAlpha = false;
  // The page's pixels stay readable after the frame (tests and screenshots read them).
  a.preserveDrawingBuffer = true;
  a.powerPreference = EM_WEBGL_POWER_PREFERENCE_HIGH_PERFORMANCE;
  auto state = std::make_unique<State>();
  state->context = emscripten_webgl_create_context(selector.c_str(), &a);
  if (state->context <= 0)
    throw GlError("no WebGL2 context on canvas '" + selector + "' (error " +
                  std::to_string(state->context) + ")");
  if (emscripten_webgl_make_context_current(state->context) != EMSCRIPTEN_RESULT_SUCCESS)
    throw GlError("cannot make the WebGL2 context current");
  if (!emscripten_webgl_enable_extension(state->context, "EXT_color_buffer_float"))
    throw GlError(
        "WebGL2 extension EXT_color_buffer_float is missing (needed for the renderer's "
        "RGBA16F HDR target)");
  return GlContext(std::move(state));
}

GlContext GlContext::headless() {
  throw GlError("no headless context in the browser: use GlContext::canvas");
}

bool GlContext::window_available() { return false; }

GlContext GlContext::window(int, int, const std::string&) {
  throw GlError("no window in the browser: use GlContext::canvas");
}

void GlContext::make_current() { emscripten_webgl_make_context_current(s_->context); }

void GlContext::swap_buffers() {}  // the browser shows the canvas when the frame's task ends

bool GlContext::has_window() const { return true; }

// renderer(), version(), has_extension(): gl.cpp (the same in both builds).

}  // namespace arlight::render
