// Internal: Reinhard's log-average luminance of the objects' pixels (thesis Alg. 5.5, fixed:
// the average over the mask, not sampled from it): block sums of (log L, 1) over the masked
// pixels, down a chain of RG32F levels to one texel, which composite.frag reads.
#pragma once

#include <filesystem>
#include <vector>

#include "arlight/render/shader.hpp"
#include "fullscreen_pass.hpp"

namespace arlight::render {

inline constexpr int kReduceBlock = 8;  // loglum_reduce.frag's and colour_stats_reduce.frag's BLOCK

class LogLuminance {
 public:
  LogLuminance(const std::filesystem::path& shader_dir, int width, int height);

  // Reduces the HDR target's masked radiance to the 1 x 1 sum.
  void reduce(const RenderTargets& targets, const FullscreenPass& fullscreen) const;
  // The 1 x 1 level: (sum of log luminance, count).
  GLuint sum_texture() const { return levels_.back().tex.id; }
  // exp(mean log luminance) of the last reduce() (a readback: for tests and tools).
  float log_average() const;

 private:
  struct Level {
    gl::Framebuffer fbo;
    gl::Texture tex;
    int w, h;
  };
  Program first_, rest_;
  std::vector<Level> levels_;  // down to 1 x 1
};

}  // namespace arlight::render
