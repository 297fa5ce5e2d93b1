#include "colour_statistics.hpp"

#include <glm/gtc/type_ptr.hpp>
#include <string>

#include "arlight/render/colour.hpp"
#include "log_luminance.hpp"

namespace arlight::render {

namespace {
constexpr int kColourStep = 2;  // colour matching measures every 2nd pixel across and down
}  // namespace

void ColourStatistics::make_levels(int width, int height) {
  const std::string block = std::to_string(kReduceBlock);
  first_ = Program(shader_dir_, "fullscreen.vert", "colour_stats_reduce.frag",
                   {{"BLOCK", block}, {"FIRST_PASS", "1"}, {"STEP", std::to_string(kColourStep)}});
  rest_ = Program(shader_dir_, "fullscreen.vert", "colour_stats_reduce.frag", {{"BLOCK", block}});
  for (int lw = width, lh = height; lw > 1 || lh > 1 || levels_.empty();) {
    const int span = kReduceBlock * (levels_.empty() ? kColourStep : 1);
    lw = (lw + span - 1) / span, lh = (lh + span - 1) / span;
    Level& l = levels_.emplace_back();
    l.w = lw, l.h = lh;
    l.fbo.create();
    glBindFramebuffer(GL_FRAMEBUFFER, l.fbo.id);
    for (auto [tex, attachment] :
         {std::pair{&l.sum, GL_COLOR_ATTACHMENT0}, std::pair{&l.sum2, GL_COLOR_ATTACHMENT1}}) {
      make_target_texture(*tex, GL_RGBA32F, GL_RGBA, GL_FLOAT, lw, lh);
      glFramebufferTexture2D(GL_FRAMEBUFFER, attachment, GL_TEXTURE_2D, tex->id, 0);
    }
    const GLenum both[2] = {GL_COLOR_ATTACHMENT0, GL_COLOR_ATTACHMENT1};
    glDrawBuffers(2, both);
    gl::check_framebuffer("colour statistics level (2 x RGBA32F)");
  }
}

void ColourStatistics::measure(const RenderTargets& targets, float exposure_gain,
                               const FullscreenPass& fullscreen) {
  if (levels_.empty()) make_levels(targets.w, targets.h);
  GLuint input = targets.hdr_tex.id, input2 = targets.mask_tex.id;
  int in_w = targets.w, in_h = targets.h;
  for (std::size_t i = 0; i < levels_.size(); ++i) {
    const Program& prog = i == 0 ? first_ : rest_;
    glUseProgram(prog.id());
    glUniform1i(prog.uniform("u_input"), 0);
    glUniform1i(prog.uniform("u_input2"), 1);
    glUniform2i(prog.uniform("u_input_size"), in_w, in_h);
    if (i == 0) {
      glUniform1f(prog.uniform("u_exposure_gain"), exposure_gain);
      const glm::mat3 lab = lab_from_rgb();
      glUniformMatrix3fv(prog.uniform("u_lab_from_rgb"), 1, GL_FALSE, glm::value_ptr(lab));
    }
    glActiveTexture(GL_TEXTURE0);
    glBindTexture(GL_TEXTURE_2D, input);
    glActiveTexture(GL_TEXTURE1);
    glBindTexture(GL_TEXTURE_2D, input2);
    glBindFramebuffer(GL_FRAMEBUFFER, levels_[i].fbo.id);
    glViewport(0, 0, levels_[i].w, levels_[i].h);
    fullscreen.draw_triangle();
    input = levels_[i].sum.id, input2 = levels_[i].sum2.id;
    in_w = levels_[i].w, in_h = levels_[i].h;
  }
}

}  // namespace arlight::render
