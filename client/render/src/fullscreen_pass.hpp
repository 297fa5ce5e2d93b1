// Internal: the one draw every full-screen pass makes. fullscreen.vert's triangle and the shadow
// catcher's rectangle take their vertices from gl_VertexID, so they draw from a VAO without
// buffers (ES 3 needs one bound); this owns it, as Filament's PostProcessManager owns the
// full-screen triangle all its passes share.
#pragma once

#include <glm/mat3x3.hpp>
#include <glm/mat4x4.hpp>

#include "gl.hpp"

namespace arlight::render {

class FullscreenPass {
 public:
  FullscreenPass();  // needs a current context
  ~FullscreenPass();
  FullscreenPass(const FullscreenPass&) = delete;
  FullscreenPass& operator=(const FullscreenPass&) = delete;

  // fullscreen.vert's one triangle over the viewport.
  void draw_triangle() const { draw(GL_TRIANGLES, 3); }
  // shadow_catcher.vert's rectangle: four vertices, a strip.
  void draw_rectangle() const { draw(GL_TRIANGLE_STRIP, 4); }

 private:
  void draw(GLenum mode, GLsizei count) const;
  GLuint vao_ = 0;
};

// The renderer's two targets, made once at its size: the HDR target the objects are drawn into
// (RGBA16F radiance + R8 mask + depth) and the output the composite is made in (RGB8 holding
// the camera frame, sharing the HDR depth so the composite touches only the objects' pixels).
struct RenderTargets {
  RenderTargets(int width, int height);
  int w, h;
  gl::Framebuffer hdr_fbo, out_fbo;
  gl::Texture hdr_tex, mask_tex, out_tex;
  gl::Renderbuffer depth;
};

// The camera and the lighting's frame a draw is made with (the material and shadow passes); a
// draw deferred to composite() (live glass) keeps the ones it was made with.
struct DrawState {
  glm::mat4 view_proj;
  glm::vec3 camera_position;
  glm::mat3 world_from_scene;
};

// A w x h texture of one level with nearest sampling, clamped: the passes' targets.
void make_target_texture(gl::Texture& tex, GLenum internal, GLenum format, GLenum type, int w,
                         int h);

}  // namespace arlight::render
