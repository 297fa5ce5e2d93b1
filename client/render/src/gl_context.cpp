// The EGL side of the renderer (native only): a headless surfaceless context on Mesa, or an X11
// window. The browser build replaces this file with a WebGL2 context; everything else in the
// renderer only needs a current GLES 3 / WebGL2 context (gl.hpp).
#include "arlight/render/gl_context.hpp"

#include <EGL/egl.h>
#include <EGL/eglext.h>

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>

#include "gl.hpp"

#ifdef ARLIGHT_HAVE_X11
#include <X11/Xlib.h>
#endif

namespace arlight::render {

namespace {

std::string egl_error(const char* what) {
  char buf[16];
  std::snprintf(buf, sizeof buf, "0x%04x", unsigned(eglGetError()));
  return std::string(what) + " failed (EGL error " + buf + ")";
}

bool has_word(const char* list, const char* word) {
  if (!list) return false;
  const std::size_t n = std::strlen(word);
  for (const char* p = std::strstr(list, word); p; p = std::strstr(p + 1, word))
    if ((p == list || p[-1] == ' ') && (p[n] == ' ' || p[n] == '\0')) return true;
  return false;
}

}  // namespace

struct GlContext::State {
  EGLDisplay display = EGL_NO_DISPLAY;
  EGLContext context = EGL_NO_CONTEXT;
  EGLSurface surface = EGL_NO_SURFACE;
#ifdef ARLIGHT_HAVE_X11
  Display* x_display = nullptr;
  Window x_window = 0;
#endif

  ~State() {
    if (display != EGL_NO_DISPLAY) {
      eglMakeCurrent(display, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
      if (surface != EGL_NO_SURFACE) eglDestroySurface(display, surface);
      if (context != EGL_NO_CONTEXT) eglDestroyContext(display, context);
      eglTerminate(display);
    }
#ifdef ARLIGHT_HAVE_X11
    if (x_display) {
      if (x_window) XDestroyWindow(x_display, x_window);
      XCloseDisplay(x_display);
    }
#endif
  }

  // Chooses an ES 3 config for `surface_type`, creates the context and makes it current.
  void create_context(EGLint surface_type) {
    if (!eglBindAPI(EGL_OPENGL_ES_API)) throw GlError(egl_error("eglBindAPI(EGL_OPENGL_ES_API)"));
    const EGLint attribs[] = {EGL_RENDERABLE_TYPE, EGL_OPENGL_ES3_BIT, EGL_SURFACE_TYPE,
                              surface_type, EGL_RED_SIZE, 8, EGL_GREEN_SIZE, 8, EGL_BLUE_SIZE, 8,
                              EGL_DEPTH_SIZE, surface_type ? 24 : 0, EGL_NONE};
    EGLConfig config = nullptr;
    EGLint n = 0;
    if (!eglChooseConfig(display, attribs, &config, 1, &n) || n < 1)
      throw GlError("eglChooseConfig: no OpenGL ES 3 config" +
                    std::string(surface_type ? " with a window surface" : ""));
    const EGLint ctx_attribs[] = {EGL_CONTEXT_MAJOR_VERSION, 3, EGL_NONE};
    context = eglCreateContext(display, config, EGL_NO_CONTEXT, ctx_attribs);
    if (context == EGL_NO_CONTEXT) throw GlError(egl_error("eglCreateContext (OpenGL ES 3)"));
    if (surface_type) create_window_surface(config);
    if (!eglMakeCurrent(display, surface, surface, context))
      throw GlError(egl_error("eglMakeCurrent"));
  }

  void create_window_surface([[maybe_unused]] EGLConfig config) {
#ifdef ARLIGHT_HAVE_X11
    surface = eglCreateWindowSurface(display, config, EGLNativeWindowType(x_window), nullptr);
    if (surface == EGL_NO_SURFACE) throw GlError(egl_error("eglCreateWindowSurface"));
#endif
  }

  void initialize() {
    EGLint major = 0, minor = 0;
    if (!eglInitialize(display, &major, &minor)) throw GlError(egl_error("eglInitialize"));
  }
};

GlContext::GlContext(std::unique_ptr<State> s) : s_(std::move(s)) {}
GlContext::GlContext(GlContext&&) noexcept = default;
GlContext& GlContext::operator=(GlContext&&) noexcept = default;
GlContext::~GlContext() = default;

GlContext GlContext::headless() {
  const char* client_ext = eglQueryString(EGL_NO_DISPLAY, EGL_EXTENSIONS);
  if (!has_word(client_ext, "EGL_MESA_platform_surfaceless"))
    throw GlError("EGL client extension EGL_MESA_platform_surfaceless is missing (needs Mesa)");
  auto get_platform_display = reinterpret_cast<PFNEGLGETPLATFORMDISPLAYEXTPROC>(
      eglGetProcAddress("eglGetPlatformDisplayEXT"));
  if (!get_platform_display) throw GlError("eglGetPlatformDisplayEXT is not available");
  auto s = std::make_unique<State>();
  s->display = get_platform_display(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr);
  if (s->display == EGL_NO_DISPLAY)
    throw GlError(egl_error("eglGetPlatformDisplayEXT(EGL_PLATFORM_SURFACELESS_MESA)"));
  s->initialize();
  if (!has_word(eglQueryString(s->display, EGL_EXTENSIONS), "EGL_KHR_surfaceless_context"))
    throw GlError("EGL extension EGL_KHR_surfaceless_context is missing");
  s->create_context(0);
  return GlContext(std::move(s));
}

bool GlContext::window_available() {
#ifdef ARLIGHT_HAVE_X11
  const char* d = std::getenv("DISPLAY");
  return d && *d;
#else
  return false;
#endif
}

GlContext GlContext::window([[maybe_unused]] int width, [[maybe_unused]] int height,
                            [[maybe_unused]] const std::string& title) {
#ifdef ARLIGHT_HAVE_X11
  if (!window_available()) throw GlError("no display: $DISPLAY is not set");
  auto s = std::make_unique<State>();
  s->x_display = XOpenDisplay(nullptr);
  if (!s->x_display) throw GlError("no display: XOpenDisplay failed for $DISPLAY");
  const int screen = DefaultScreen(s->x_display);
  s->x_window = XCreateSimpleWindow(s->x_display, RootWindow(s->x_display, screen), 0, 0,
                                    unsigned(width), unsigned(height), 0, 0, 0);
  XStoreName(s->x_display, s->x_window, title.c_str());
  XMapWindow(s->x_display, s->x_window);
  XFlush(s->x_display);
  s->display = eglGetDisplay(EGLNativeDisplayType(s->x_display));
  if (s->display == EGL_NO_DISPLAY) throw GlError(egl_error("eglGetDisplay(X11)"));
  s->initialize();
  s->create_context(EGL_WINDOW_BIT);
  return GlContext(std::move(s));
#else
  throw GlError("no display: arlight_render was built without X11 (libx11-dev)");
#endif
}

GlContext GlContext::canvas(const std::string& selector) {
  throw GlError("no canvas '" + selector + "' in a native build: a canvas is the browser build's");
}

void GlContext::make_current() {
  if (!eglMakeCurrent(s_->display, s_->surface, s_->surface, s_->context))
    throw GlError(egl_error("eglMakeCurrent"));
}

void GlContext::swap_buffers() {
  if (s_->surface != EGL_NO_SURFACE && !eglSwapBuffers(s_->display, s_->surface))
    throw GlError(egl_error("eglSwapBuffers"));
}

bool GlContext::has_window() const { return s_->surface != EGL_NO_SURFACE; }

// renderer(), version(), has_extension(): gl.cpp (the same in both builds).

}  // namespace arlight::render
