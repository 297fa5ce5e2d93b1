#include "log_luminance.hpp"

#include <algorithm>
#include <cmath>
#include <string>

namespace arlight::render {

LogLuminance::LogLuminance(const std::filesystem::path& shader_dir, int width, int height) {
  const std::string block = std::to_string(kReduceBlock);
  first_ = Program(shader_dir, "fullscreen.vert", "loglum_reduce.frag",
                   {{"BLOCK", block}, {"FIRST_PASS", "1"}});
  rest_ = Program(shader_dir, "fullscreen.vert", "loglum_reduce.frag", {{"BLOCK", block}});
  // Each level sums BLOCK x BLOCK texels of the one above; a 1x1 renderer still needs the sum.
  for (int lw = width, lh = height; lw > 1 || lh > 1 || levels_.empty();) {
    lw = (lw + kReduceBlock - 1) / kReduceBlock, lh = (lh + kReduceBlock - 1) / kReduceBlock;
    Level& l = levels_.emplace_back();
    l.w = lw, l.h = lh;
    make_target_texture(l.tex, GL_RG32F, GL_RG, GL_FLOAT, lw, lh);
    l.fbo.create();
    glBindFramebuffer(GL_FRAMEBUFFER, l.fbo.id);
    glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, l.tex.id, 0);
    gl::check_framebuffer("log-luminance reduction level (RG32F)");
  }
}

void LogLuminance::reduce(const RenderTargets& targets, const FullscreenPass& fullscreen) const {
  GLuint input = targets.hdr_tex.id;
  int in_w = targets.w, in_h = targets.h;
  for (std::size_t i = 0; i < levels_.size(); ++i) {
    const Program& prog = i == 0 ? first_ : rest_;
    glUseProgram(prog.id());
    glUniform1i(prog.uniform("u_input"), 0);
    glUniform1i(prog.uniform("u_mask"), 1);
    glUniform2i(prog.uniform("u_input_size"), in_w, in_h);
    glActiveTexture(GL_TEXTURE0);
    glBindTexture(GL_TEXTURE_2D, input);
    glActiveTexture(GL_TEXTURE1);
    glBindTexture(GL_TEXTURE_2D, targets.mask_tex.id);
    glBindFramebuffer(GL_FRAMEBUFFER, levels_[i].fbo.id);
    glViewport(0, 0, levels_[i].w, levels_[i].h);
    fullscreen.draw_triangle();
    input = levels_[i].tex.id, in_w = levels_[i].w, in_h = levels_[i].h;
  }
}

float LogLuminance::log_average() const {
  float sum[4] = {0, 0, 0, 0};
  glBindFramebuffer(GL_READ_FRAMEBUFFER, levels_.back().fbo.id);
  glReadPixels(0, 0, 1, 1, GL_RGBA, GL_FLOAT, sum);
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
  return std::exp(sum[0] / std::max(sum[1], 1.0f));
}

}  // namespace arlight::render
