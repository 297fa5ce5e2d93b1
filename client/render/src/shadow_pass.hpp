// Internal: the shadow catcher (ShadowSettings; tutorial §6.3's differential rendering), as
// separate steps: the casters gathered from the frame's draws; the receiver, the rectangle of
// the floor (the scene's z = 0) the shadows can reach; one depth layer per hard shadow,
// re-rendered only when a light or a caster moved; the catcher's factors at 1/4 resolution;
// and their application to the camera frame, on the CPU (composite()) or by blending
// (composite_in_place()). Owns its programs, the depth layers and the factors.
#pragma once

#include <filesystem>
#include <vector>

#include "arlight/render/render.hpp"
#include "fullscreen_pass.hpp"
#include "scene_lighting.hpp"
#include "shadow_lights.hpp"

namespace arlight::render {

class ShadowPass {
 public:
  ShadowPass(const std::filesystem::path& shader_dir, int width, int height);

  // Throws std::invalid_argument for a map_size outside [16, 4096].
  void set_settings(const ShadowSettings& settings);
  const ShadowSettings& settings() const { return settings_; }
  float fraction(const SceneLighting& lighting, const glm::mat3& world_from_scene) const {
    return lights_.fraction(settings_, lighting, world_from_scene);
  }

  void begin_frame() { casters_.clear(); }
  // A mesh drawn this frame casts a shadow (when shadows are on).
  void add_caster(const GpuMesh& mesh, const glm::mat4& model, const glm::mat3& world_from_scene);
  bool active() const { return settings_.enabled && !casters_.empty(); }

  // The depth layers and the catcher's factors; false when there is nothing to shadow.
  // `light_count` is set to the hard shadows blended.
  bool draw_factors(const DrawState& view, const SceneLighting& lighting, GLuint response_lut,
                    const FullscreenPass& fullscreen, int& light_count);
  // The factors read back and multiplied into a copy of the frame: true when some are below 1,
  // and shadowed() then holds the frame with them applied.
  bool apply_on_cpu(const ImageU8View& frame);
  const ImageU8& shadowed() const { return shadowed_; }
  // The factors multiplied into the output's camera frame by blending.
  void apply_on_gpu(const RenderTargets& targets, const glm::mat4& view_proj, bool rgb,
                    const FullscreenPass& fullscreen);

 private:
  // A mesh drawn this frame: its scene-frame bounds and what draws it.
  struct Caster {
    GLuint vao;
    GLsizei count;
    glm::mat4 model;
    glm::vec3 lo, hi;  // scene-frame AABB
    // The mesh's baked floor occlusion when the mesh stands on the floor (its bake plane is the
    // scene's z = 0, its +Y the scene's +Z), else 0: the catcher then uses the ellipsoid.
    GLuint ground_tex = 0;
    glm::mat4 ground_from_scene{1.0f};  // scene point -> (u, v) of the ground texture
    GLuint ground_transfer_tex = 0;     // its SH-9 hidden transfer, when baked
    glm::mat3 world_from_object{1.0f};  // the model's rotation in the lighting's frame
  };

  glm::vec4 receiver_rect(const std::vector<ShadowLight>& lights, float size) const;
  void ensure_resources(int layers);
  void render_depth_layers(const std::vector<glm::mat4>& light_view_proj);
  void set_ground_uniforms(const std::vector<ShadowLight>& lights, const ShCoeffs& room_sh);
  void draw_catcher(const std::vector<ShadowLight>& lights,
                    const std::vector<glm::mat4>& shadow_from_scene, const DrawState& view,
                    const ShCoeffs& room_sh, GLuint response_lut, const FullscreenPass& fullscreen);

  std::filesystem::path shader_dir_;
  int w_, h_;
  ShadowSettings settings_;
  ShadowLightChooser lights_;
  std::vector<Caster> casters_;
  Program depth_, catcher_, apply_, apply_rgb_;  // made when first used
  gl::Texture shadow_tex_, factor_tex_;          // shadow_tex_: one depth layer per light
  gl::Framebuffer shadow_fbo_, factor_fbo_;
  gl::Texture white_tex_;  // the catcher's floor occlusion where none was baked
  int shadow_size_ = 0, shadow_layers_ = 0, factor_w_ = 0, factor_h_ = 0;
  std::vector<float> shadow_key_;  // what the depth layers hold (lights, casters); empty: nothing
  glm::vec4 rect_{0.0f};           // the catcher's rectangle of z = 0: (x0, y0, x1, y1)
  // apply_on_cpu's buffers: the low-resolution factors read back, the frame with them applied,
  // the factor rows upsampled across, and per column of the box the left factor texel and the
  // right one's weight.
  std::vector<std::uint8_t> factors_;
  ImageU8 shadowed_;
  std::vector<float> across_;
  std::vector<int> taps_;
  std::vector<float> weights_;
};

}  // namespace arlight::render
