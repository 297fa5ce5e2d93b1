#include "composite_pass.hpp"

#include <glm/gtc/type_ptr.hpp>
#include <string>

#include "arlight/render/colour.hpp"

namespace arlight::render {

namespace {

int tone_mode_define(ToneMode mode) {  // composite.frag's TONE_MODE
  return mode == ToneMode::CameraMatched ? 0 : mode == ToneMode::Reinhard ? 1 : 2;
}

}  // namespace

CompositePass::CompositePass(const std::filesystem::path& shader_dir) : shader_dir_(shader_dir) {
  for (int mode = 0; mode < 3; ++mode) program(mode, ColourCorrection::None, false);
  present_ = Program(shader_dir, "fullscreen.vert", "present.frag", {{"FRAME_RGB", "0"}});
}

// composite.frag by ToneMode | ColourCorrection << 2 | (a frame stored R, G, B) << 4.
const Program& CompositePass::program(int mode, ColourCorrection colour, bool rgb) {
  const unsigned key = unsigned(mode) | unsigned(colour) << 2 | (rgb ? 16u : 0u);
  if (auto it = programs_.find(key); it != programs_.end()) return it->second;
  Program c(shader_dir_, "fullscreen.vert", "composite.frag",
            {{"TONE_MODE", std::to_string(mode)},
             {"COLOUR_MODE", std::to_string(int(colour))},
             {"FRAME_RGB", rgb ? "1" : "0"}});
  glUseProgram(c.id());
  glUniform1i(c.uniform("u_hdr"), 0);
  glUniform1i(c.uniform("u_response"), 2);
  glUniform1i(c.uniform("u_log_sum"), 3);
  glUniform1i(c.uniform("u_colour_sum"), 4);
  glUniform1i(c.uniform("u_colour_sum2"), 5);
  const glm::mat3 lab = lab_from_rgb(), rgb_of_lab = rgb_from_lab();
  glUniformMatrix3fv(c.uniform("u_lab_from_rgb"), 1, GL_FALSE, glm::value_ptr(lab));
  glUniformMatrix3fv(c.uniform("u_rgb_from_lab"), 1, GL_FALSE, glm::value_ptr(rgb_of_lab));
  return programs_.emplace(key, std::move(c)).first->second;
}

void CompositePass::draw(const RenderTargets& targets, const ToneMapping& tone, bool rgb,
                         const CompositeInputs& in, const FullscreenPass& fullscreen) {
  const Program& comp = program(tone_mode_define(tone.mode), tone.colour, rgb);
  glUseProgram(comp.id());
  const float eg = float(tone.exposure * tone.gain);
  if (tone.colour == ColourCorrection::Match) {
    const EnvironmentPriors& room = in.lighting->environment_priors();
    glUniform3fv(comp.uniform("u_source_mean"), 1, glm::value_ptr(room.lab.mean * eg));
    glUniform3fv(comp.uniform("u_source_sd"), 1, glm::value_ptr(room.lab.sd * eg));
    glActiveTexture(GL_TEXTURE4);
    glBindTexture(GL_TEXTURE_2D, in.colour->sum());
    glActiveTexture(GL_TEXTURE5);
    glBindTexture(GL_TEXTURE_2D, in.colour->sum2());
  } else if (tone.colour != ColourCorrection::None) {
    const EnvironmentPriors& room = in.lighting->environment_priors();
    glUniform3f(comp.uniform("u_grey"), room.grey_low, room.grey_mean, room.grey_high);
  }
  glUniform1f(comp.uniform("u_exposure_gain"), eg);
  glUniform1f(comp.uniform("u_key"), tone.key);
  glUniform1f(comp.uniform("u_white"), tone.white);
  glActiveTexture(GL_TEXTURE0);
  glBindTexture(GL_TEXTURE_2D, targets.hdr_tex.id);
  glActiveTexture(GL_TEXTURE2);
  glBindTexture(GL_TEXTURE_2D, in.response_lut);
  glActiveTexture(GL_TEXTURE3);
  glBindTexture(GL_TEXTURE_2D, in.log_sum);
  glBindFramebuffer(GL_FRAMEBUFFER, targets.out_fbo.id);
  glViewport(0, 0, targets.w, targets.h);
  glEnable(GL_DEPTH_TEST);  // fullscreen.vert draws at the far plane: passes where depth < 1
  glDepthFunc(GL_GREATER);
  glDepthMask(GL_FALSE);
  // Over the frame by the objects' coverage (below 1 only where alpha-blended surfaces are
  // alone).
  if (in.blended) {
    glEnable(GL_BLEND);
    glBlendFuncSeparate(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA, GL_ZERO, GL_ONE);
  }
  fullscreen.draw_triangle();
  glDisable(GL_BLEND);
  glDepthMask(GL_TRUE);
  glDepthFunc(GL_LESS);
  glDisable(GL_DEPTH_TEST);
  gl::check("tone mapping and compositing");
}

void CompositePass::present(const RenderTargets& targets, bool rgb,
                            const FullscreenPass& fullscreen) {
  if (rgb && !present_rgb_.id())
    present_rgb_ = Program(shader_dir_, "fullscreen.vert", "present.frag", {{"FRAME_RGB", "1"}});
  const Program& present = rgb ? present_rgb_ : present_;
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
  glDisable(GL_DEPTH_TEST);
  glDisable(GL_CULL_FACE);
  glUseProgram(present.id());
  glUniform1i(present.uniform("u_image"), 0);
  glActiveTexture(GL_TEXTURE0);
  glBindTexture(GL_TEXTURE_2D, targets.out_tex.id);
  fullscreen.draw_triangle();
  gl::check("present");
}

}  // namespace arlight::render
