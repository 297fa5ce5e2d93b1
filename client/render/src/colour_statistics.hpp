// Internal: colour matching's statistics of the virtual pixels (dissertation §5.6): the sums and
// sums of squares of their l alpha beta values (lab_from_rgb()) at the frame's exposure, over every
// 2nd pixel across and down (colour_stats_reduce.frag), reduced to one texel each, which
// composite.frag turns into their mean and spread. Levels and programs are made when first used.
#pragma once

#include <filesystem>
#include <vector>

#include "arlight/render/shader.hpp"
#include "fullscreen_pass.hpp"

namespace arlight::render {

class ColourStatistics {
 public:
  explicit ColourStatistics(const std::filesystem::path& shader_dir) : shader_dir_(shader_dir) {}

  void measure(const RenderTargets& targets, float exposure_gain, const FullscreenPass& fullscreen);
  // The 1 x 1 sums (RGBA32F: l, alpha, beta, count) and sums of squares of the last measure().
  GLuint sum() const { return levels_.back().sum.id; }
  GLuint sum2() const { return levels_.back().sum2.id; }

 private:
  void make_levels(int width, int height);

  struct Level {
    gl::Framebuffer fbo;
    gl::Texture sum, sum2;
    int w, h;
  };
  std::filesystem::path shader_dir_;
  Program first_, rest_;
  std::vector<Level> levels_;  // down to 1 x 1
};

}  // namespace arlight::render
