#include "live_glass.hpp"

#include <chrono>

namespace arlight::render {

double LiveGlass::draw(const RenderTargets& targets, const ToneMapping& tone, bool rgb,
                       IblPass& ibl, const SceneLighting& lighting, GLuint response_inverse) {
  if (deferred_.empty()) return 0.0;
  const auto t0 = std::chrono::steady_clock::now();
  if (!frame_copy_.id) {
    frame_copy_.create();
    glBindTexture(GL_TEXTURE_2D, frame_copy_.id);
    glTexImage2D(GL_TEXTURE_2D, 0, GL_RGB8, targets.w, targets.h, 0, GL_RGB, GL_UNSIGNED_BYTE,
                 nullptr);
    gl::set_sampling(GL_TEXTURE_2D, GL_LINEAR, GL_CLAMP_TO_EDGE, GL_CLAMP_TO_EDGE);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAX_LEVEL, 0);
  }
  // The output holds the frame now (uploaded, or the page's); the glass samples a copy of it.
  glBindFramebuffer(GL_FRAMEBUFFER, targets.out_fbo.id);
  glActiveTexture(GL_TEXTURE0 + IblPass::kFrameUnit);
  glBindTexture(GL_TEXTURE_2D, frame_copy_.id);
  glCopyTexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, 0, 0, targets.w, targets.h);
  const LiveFrameInputs live{frame_copy_.id, rgb, response_inverse,
                             float(1.0 / (tone.exposure * tone.gain))};
  for (const Deferred& d : deferred_)
    ibl.draw(*d.mesh, d.material, d.model, d.state, lighting, targets, d.part, &live);
  deferred_.clear();
  // Back to the full-screen passes' state.
  glDisable(GL_DEPTH_TEST);
  glDisable(GL_CULL_FACE);
  if (!rgb) glFinish();  // composite() waits for the GPU anyway: time this part on its own
  gl::check("live refraction");
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace arlight::render
