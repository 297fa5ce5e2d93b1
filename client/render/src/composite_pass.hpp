// Internal: the composite, the frame's last passes. The objects' pixels of the HDR target tone
// mapped (ToneMode: tutorial §4.1's camera-matched response, thesis Alg. 5.5's Reinhard, or
// linear) and colour corrected (dissertation §5.6) into the output, whose other pixels hold
// the camera frame; and present(), the output shown in a window. Owns composite.frag's
// variants (by tone mode, correction and channel order, made when first used) and present.frag.
#pragma once

#include <filesystem>
#include <unordered_map>

#include "arlight/render/render.hpp"
#include "colour_statistics.hpp"
#include "fullscreen_pass.hpp"
#include "scene_lighting.hpp"

namespace arlight::render {

// What composite.frag reads besides the HDR target.
struct CompositeInputs {
  GLuint response_lut;             // the camera response (CameraMatched)
  GLuint log_sum;                  // LogLuminance::sum_texture() (Reinhard)
  const ColourStatistics* colour;  // measured this frame (ColourCorrection::Match)
  const SceneLighting* lighting;   // its environment_priors() (any correction)
  // Alpha-blended surfaces were drawn this frame: blend by the HDR target's coverage (costs
  // 0.7 ms a frame at 1280 x 720 on llvmpipe, so only then; elsewhere the coverage is 1).
  bool blended = false;
};

class CompositePass {
 public:
  // Compiles the tone modes' variants without colour correction now (shader errors show up at
  // construction).
  explicit CompositePass(const std::filesystem::path& shader_dir);

  // Into targets.out_fbo where the objects are (depth < 1); `rgb`: the output holds R, G, B (the
  // browser's frame), else B, G, R.
  void draw(const RenderTargets& targets, const ToneMapping& tone, bool rgb,
            const CompositeInputs& in, const FullscreenPass& fullscreen);
  // The output in the default framebuffer, rows flipped (a window's row 0 is its bottom) and B
  // and R swapped unless it holds R, G, B.
  void present(const RenderTargets& targets, bool rgb, const FullscreenPass& fullscreen);

 private:
  const Program& program(int mode, ColourCorrection colour, bool rgb);

  std::filesystem::path shader_dir_;
  std::unordered_map<unsigned, Program> programs_;
  Program present_, present_rgb_;
};

}  // namespace arlight::render
