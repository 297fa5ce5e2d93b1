#include "shadow_pass.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/type_ptr.hpp>
#include <stdexcept>
#include <string>

#include "ibl_pass.hpp"
#include "textures.hpp"

namespace arlight::render {

namespace {

constexpr int kMaxEllipsoids = 4;       // shadow_catcher.frag's u_centre / u_inv_axes / u_ground*
constexpr int kGroundUnit = 3;          // the catcher's texture units of u_ground0..3
constexpr int kGroundTransferUnit = 7;  // ... and of u_ground_transfer0..3
constexpr int kFactorScale = 4;         // shadow factors at 1/4 of the output's width and height

// The corner i (0-7) of the box lo..hi.
glm::vec3 corner(const glm::vec3& lo, const glm::vec3& hi, int i) {
  return {i & 1 ? hi.x : lo.x, i & 2 ? hi.y : lo.y, i & 4 ? hi.z : lo.z};
}

// An orthographic view from direction l fitted to the box lo..hi, with a margin of a few
// shadow-map texels for the PCF taps.
glm::mat4 fit_light_view(const glm::vec3& l, const glm::vec3& lo, const glm::vec3& hi, float size,
                         float pcf_step, int map_size) {
  const glm::vec3 centre = 0.5f * (lo + hi);
  const glm::vec3 up_hint = std::abs(l.z) < 0.99f ? glm::vec3(0, 0, 1) : glm::vec3(0, 1, 0);
  const glm::mat4 view = glm::lookAt(centre + l * (2.0f * size), centre, up_hint);
  glm::vec3 a(1e30f), b(-1e30f);
  for (int i = 0; i < 8; ++i) {
    const glm::vec3 v = glm::vec3(view * glm::vec4(corner(lo, hi, i), 1.0f));
    a = glm::min(a, v), b = glm::max(b, v);
  }
  const float margin = (b.x - a.x + b.y - a.y) * (pcf_step + 2.0f) / float(map_size);
  const glm::mat4 proj = glm::ortho(a.x - margin, b.x + margin, a.y - margin, b.y + margin,
                                    -b.z - margin, -a.z + margin);
  return proj * view;
}

}  // namespace

ShadowPass::ShadowPass(const std::filesystem::path& shader_dir, int width, int height)
    : shader_dir_(shader_dir), w_(width), h_(height) {}

void ShadowPass::set_settings(const ShadowSettings& settings) {
  if (settings.map_size < 16 || settings.map_size > 4096)
    throw std::invalid_argument("set_shadow: map_size must be in [16, 4096]");
  settings_ = settings;
}

void ShadowPass::add_caster(const GpuMesh& mesh, const glm::mat4& model,
                            const glm::mat3& world_from_scene) {
  if (!settings_.enabled) return;
  Caster c{mesh.vao(), GLsizei(mesh.index_count()), model, glm::vec3(1e30f), glm::vec3(-1e30f)};
  const Bounds& b = mesh.bounds();
  for (int i = 0; i < 8; ++i) {
    const glm::vec3 q = glm::vec3(model * glm::vec4(corner(b.min, b.max, i), 1.0f));
    c.lo = glm::min(c.lo, q), c.hi = glm::max(c.hi, q);
  }
  // The baked floor applies where the bake's plane (y = min.y, object frame) is the floor.
  const glm::vec3 up = glm::normalize(glm::mat3(model) * glm::vec3(0, 1, 0));
  const float floor_z = (model * glm::vec4(b.centre().x, b.min.y, b.centre().z, 1.0f)).z;
  const GroundOcclusion& g = mesh.ground_rect();
  if (mesh.ground_texture() && up.z > 0.999f &&
      std::abs(floor_z) <= 1e-3f * std::max(glm::length(c.hi - c.lo), 1e-6f)) {
    // (x, z) of the object frame onto [0, 1]^2 of the texture.
    glm::mat4 to_uv(0.0f);
    to_uv[0][0] = 1.0f / (g.max.x - g.min.x), to_uv[3][0] = -g.min.x / (g.max.x - g.min.x);
    to_uv[2][1] = 1.0f / (g.max.y - g.min.y), to_uv[3][1] = -g.min.y / (g.max.y - g.min.y);
    to_uv[3][3] = 1.0f;
    c.ground_tex = mesh.ground_texture();
    c.ground_from_scene = to_uv * glm::inverse(model);
    c.ground_transfer_tex = mesh.ground_transfer_texture();
    c.world_from_object = world_from_object(world_from_scene, model);
  }
  casters_.push_back(c);
}

void ShadowPass::ensure_resources(int layers) {
  if (!factor_fbo_.id) {  // made last below: a failed compile is tried again next frame
    depth_ = Program(shader_dir_, "shadow_depth.vert", "shadow_depth.frag");
    catcher_ = Program(shader_dir_, "shadow_catcher.vert", "shadow_catcher.frag");
    glUseProgram(catcher_.id());
    glUniform1i(catcher_.uniform("u_shadow_maps"), 0);
    glUniform1i(catcher_.uniform("u_response"), 2);
    for (int k = 0; k < kMaxEllipsoids; ++k) {
      glUniform1i(catcher_.uniform(("u_ground" + std::to_string(k)).c_str()), kGroundUnit + k);
      glUniform1i(catcher_.uniform(("u_ground_transfer" + std::to_string(k)).c_str()),
                  kGroundTransferUnit + k);
    }
    white_tex_ = upload_pixel_texture({255, 255, 255, 255});
    // The factors at 1/kFactorScale of the output's resolution (shadows are smooth).
    factor_w_ = (w_ + kFactorScale - 1) / kFactorScale,
    factor_h_ = (h_ + kFactorScale - 1) / kFactorScale;
    factor_tex_.create();
    glBindTexture(GL_TEXTURE_2D, factor_tex_.id);
    glTexImage2D(GL_TEXTURE_2D, 0, GL_RGBA8, factor_w_, factor_h_, 0, GL_RGBA, GL_UNSIGNED_BYTE,
                 nullptr);
    gl::set_sampling(GL_TEXTURE_2D, GL_LINEAR, GL_CLAMP_TO_EDGE, GL_CLAMP_TO_EDGE);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAX_LEVEL, 0);
    factor_fbo_.create();
    glBindFramebuffer(GL_FRAMEBUFFER, factor_fbo_.id);
    glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, factor_tex_.id, 0);
    gl::check_framebuffer("shadow factors (RGBA8)");
  }
  // One depth layer per light, grown as more lights are asked for.
  const int n = std::max(16, settings_.map_size);
  layers = std::max(layers, 1);
  if (shadow_size_ == n && shadow_layers_ >= layers) return;
  shadow_size_ = n, shadow_layers_ = std::max(layers, shadow_layers_);
  shadow_key_.clear();
  shadow_tex_ = gl::Texture();
  shadow_tex_.create();
  glBindTexture(GL_TEXTURE_2D_ARRAY, shadow_tex_.id);
  glTexImage3D(GL_TEXTURE_2D_ARRAY, 0, GL_DEPTH_COMPONENT24, n, n, shadow_layers_, 0,
               GL_DEPTH_COMPONENT, GL_UNSIGNED_INT, nullptr);
  gl::set_sampling(GL_TEXTURE_2D_ARRAY, GL_LINEAR, GL_CLAMP_TO_EDGE, GL_CLAMP_TO_EDGE);
  glTexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_MAX_LEVEL, 0);
  glTexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_COMPARE_MODE, GL_COMPARE_REF_TO_TEXTURE);
  glTexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_COMPARE_FUNC, GL_LEQUAL);
  if (!shadow_fbo_.id) shadow_fbo_.create();
  glBindFramebuffer(GL_FRAMEBUFFER, shadow_fbo_.id);
  glFramebufferTextureLayer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, shadow_tex_.id, 0, 0);
  const GLenum none = GL_NONE;
  glDrawBuffers(1, &none);
  gl::check_framebuffer("shadow maps (DEPTH_COMPONENT24 layers)");
}

bool ShadowPass::draw_factors(const DrawState& view, const SceneLighting& lighting,
                              GLuint response_lut, const FullscreenPass& fullscreen,
                              int& light_count) {
  // The casters' union bounds (scene frame).
  glm::vec3 lo(1e30f), hi(-1e30f);
  for (const Caster& c : casters_) lo = glm::min(lo, c.lo), hi = glm::max(hi, c.hi);
  if (hi.z <= 0.0f) return false;                    // everything under the floor
  if (view.camera_position.z <= 0.0f) return false;  // seen from under the floor
  const float size = std::max({hi.x - lo.x, hi.y - lo.y, hi.z - lo.z, 1e-6f});

  // The hard shadows to blend (scene frame) and their shares of the floor's light.
  const std::vector<ShadowLight> lights =
      lights_.choose(settings_, lighting, view.world_from_scene);
  light_count = int(lights.size());
  rect_ = receiver_rect(lights, size);
  ensure_resources(int(lights.size()));
  // Per light, an orthographic view fitted to the casters' bounds.
  std::vector<glm::mat4> light_view_proj, shadow_from_scene;
  const glm::mat4 to_tex = glm::translate(glm::mat4(1.0f), glm::vec3(0.5f)) *
                           glm::scale(glm::mat4(1.0f), glm::vec3(0.5f));
  for (const ShadowLight& sl : lights) {
    light_view_proj.push_back(
        fit_light_view(sl.direction, lo, hi, size, settings_.pcf_step, shadow_size_));
    shadow_from_scene.push_back(to_tex * light_view_proj.back());
  }
  if (!lights.empty()) render_depth_layers(light_view_proj);
  draw_catcher(lights, shadow_from_scene, view, lighting.room_sh(), response_lut, fullscreen);
  return true;
}

// The receiver rectangle: the objects' footprints widened to where AO fades out, and the
// shadows' reach along each -l (at most max_shadow_length object sizes).
glm::vec4 ShadowPass::receiver_rect(const std::vector<ShadowLight>& lights, float size) const {
  glm::vec2 r0(1e30f), r1(-1e30f);
  for (const Caster& c : casters_) {
    const glm::vec2 half = 0.5f * glm::vec2(c.hi - c.lo), mid = 0.5f * glm::vec2(c.hi + c.lo);
    const glm::vec2 reach = std::max(settings_.ao_reach, 0.0f) * glm::max(half, glm::vec2(1e-4f));
    r0 = glm::min(r0, mid - reach), r1 = glm::max(r1, mid + reach);
    for (const ShadowLight& sl : lights) {
      const glm::vec3 l = sl.direction;
      for (int i = 0; i < 8; ++i) {
        const glm::vec3 q = corner(c.lo, c.hi, i);
        glm::vec2 d = -glm::vec2(l) * (std::max(q.z, 0.0f) / l.z);
        const float len = glm::length(d), cap = settings_.max_shadow_length * size;
        if (len > cap) d *= cap / len;
        const glm::vec2 hit = glm::vec2(q) + d;
        r0 = glm::min(r0, hit), r1 = glm::max(r1, hit);
      }
    }
  }
  return glm::vec4(r0, r1);
}

// The depth layers are re-rendered only when a light or a caster moved (in the scene frame).
void ShadowPass::render_depth_layers(const std::vector<glm::mat4>& light_view_proj) {
  std::vector<float> key;
  for (const glm::mat4& m : light_view_proj)
    key.insert(key.end(), glm::value_ptr(m), glm::value_ptr(m) + 16);
  for (const Caster& c : casters_) {
    key.push_back(float(c.vao)), key.push_back(float(c.count));
    key.insert(key.end(), glm::value_ptr(c.model), glm::value_ptr(c.model) + 16);
  }
  if (key == shadow_key_) return;
  shadow_key_ = std::move(key);
  glBindFramebuffer(GL_FRAMEBUFFER, shadow_fbo_.id);
  glViewport(0, 0, shadow_size_, shadow_size_);
  glDisable(GL_BLEND);
  glDisable(GL_CULL_FACE);
  glEnable(GL_DEPTH_TEST);
  glDepthFunc(GL_LESS);
  glDepthMask(GL_TRUE);
  glUseProgram(depth_.id());
  const GLint u_light = depth_.uniform("u_light_view_proj");
  const GLint u_model = depth_.uniform("u_model");
  for (std::size_t i = 0; i < light_view_proj.size(); ++i) {
    glFramebufferTextureLayer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, shadow_tex_.id, 0, GLint(i));
    glClear(GL_DEPTH_BUFFER_BIT);
    glUniformMatrix4fv(u_light, 1, GL_FALSE, glm::value_ptr(light_view_proj[i]));
    for (const Caster& c : casters_) {
      glUniformMatrix4fv(u_model, 1, GL_FALSE, glm::value_ptr(c.model));
      glBindVertexArray(c.vao);
      glDrawElements(GL_TRIANGLES, c.count, GL_UNSIGNED_INT, nullptr);
    }
  }
  glBindVertexArray(0);
}

// The catcher, in two passes over the rectangle of z = 0: the code factors at low resolution
// (1 where there is no shadow) here, then upsampled bilinearly, depth tested against the
// objects (no depth writes) and multiplied into the output where they are below 1 (apply_*).
void ShadowPass::draw_catcher(const std::vector<ShadowLight>& lights,
                              const std::vector<glm::mat4>& shadow_from_scene,
                              const DrawState& view, const ShCoeffs& room_sh, GLuint response_lut,
                              const FullscreenPass& fullscreen) {
  const Program& pr = catcher_;
  glUseProgram(pr.id());
  glUniform4fv(pr.uniform("u_rect"), 1, glm::value_ptr(rect_));
  glUniformMatrix4fv(pr.uniform("u_view_proj"), 1, GL_FALSE, glm::value_ptr(view.view_proj));
  glUniform1i(pr.uniform("u_light_count"), int(lights.size()));
  float f_sum = 0.0f;
  for (const ShadowLight& sl : lights) f_sum += sl.fraction;
  if (!lights.empty()) {
    glUniformMatrix4fv(pr.uniform("u_shadow_from_scene"), GLsizei(lights.size()), GL_FALSE,
                       glm::value_ptr(shadow_from_scene[0]));
    std::array<float, kMaxShadowLights> fractions{};
    for (std::size_t i = 0; i < lights.size(); ++i) fractions[i] = lights[i].fraction;
    glUniform4fv(pr.uniform("u_light_fraction"), kMaxShadowLights / 4, fractions.data());
  }
  // Few lights: each shadow's edge softened by PCF; many: their overlap is the penumbra.
  glUniform1i(pr.uniform("u_pcf_radius"), lights.size() <= 2 ? 1 : 0);
  glUniform1f(pr.uniform("u_pcf_step"), settings_.pcf_step / float(shadow_size_));
  glUniform1f(pr.uniform("u_depth_bias"), 2.0f / float(shadow_size_));
  glUniform1f(pr.uniform("u_fraction"), f_sum);
  glUniform1f(pr.uniform("u_ao_strength"), std::max(settings_.ao_strength, 0.0f));
  glUniform1f(pr.uniform("u_ao_reach"), std::max(settings_.ao_reach, 1e-3f));
  glUniform1f(pr.uniform("u_min_ratio"), std::clamp(settings_.min_ratio, 0.0f, 1.0f));
  const int count = std::min<int>(kMaxEllipsoids, int(casters_.size()));
  std::vector<glm::vec3> centres, inv_axes;
  for (int k = 0; k < count; ++k) {
    const Caster& c = casters_[std::size_t(k)];
    centres.push_back(0.5f * (c.lo + c.hi));
    inv_axes.push_back(1.0f / glm::max(0.5f * (c.hi - c.lo), glm::vec3(1e-5f)));
  }
  glUniform1i(pr.uniform("u_count"), count);
  if (count > 0) {
    glUniform3fv(pr.uniform("u_centre"), count, glm::value_ptr(centres[0]));
    glUniform3fv(pr.uniform("u_inv_axes"), count, glm::value_ptr(inv_axes[0]));
  }
  set_ground_uniforms(lights, room_sh);
  glActiveTexture(GL_TEXTURE0);
  glBindTexture(GL_TEXTURE_2D_ARRAY, shadow_tex_.id);
  glActiveTexture(GL_TEXTURE2);
  glBindTexture(GL_TEXTURE_2D, response_lut);
  glBindFramebuffer(GL_FRAMEBUFFER, factor_fbo_.id);
  glViewport(0, 0, factor_w_, factor_h_);
  glDisable(GL_CULL_FACE);
  glDisable(GL_DEPTH_TEST);
  glDisable(GL_BLEND);
  const float one[4] = {1, 1, 1, 1};
  glClearBufferfv(GL_COLOR, 0, one);
  fullscreen.draw_rectangle();
  gl::check("shadow catcher");
}

// The casters' baked floor occlusion, where they have one (tutorial §6.1's receiver plane),
// and their floors' hidden transfer.
void ShadowPass::set_ground_uniforms(const std::vector<ShadowLight>& lights,
                                     const ShCoeffs& room_sh) {
  const Program& pr = catcher_;
  const int count = std::min<int>(kMaxEllipsoids, int(casters_.size()));
  std::vector<float> has_ground(kMaxEllipsoids, 0.0f);
  std::vector<glm::mat4> ground_from_scene(kMaxEllipsoids, glm::mat4(1.0f));
  for (int k = 0; k < kMaxEllipsoids; ++k) {
    glActiveTexture(GLenum(GL_TEXTURE0 + kGroundUnit + k));
    const bool baked = k < count && casters_[std::size_t(k)].ground_tex;
    glBindTexture(GL_TEXTURE_2D, baked ? casters_[std::size_t(k)].ground_tex : white_tex_.id);
    if (baked) {
      has_ground[std::size_t(k)] = 1.0f;
      ground_from_scene[std::size_t(k)] = casters_[std::size_t(k)].ground_from_scene;
    }
  }
  glUniform1fv(pr.uniform("u_has_ground"), kMaxEllipsoids, has_ground.data());
  glUniformMatrix4fv(pr.uniform("u_ground_from_scene"), kMaxEllipsoids, GL_FALSE,
                     glm::value_ptr(ground_from_scene[0]));
  // Where the floor's hidden transfer is baked, the light it hides is the rest of the room's (not
  // drawn as hard shadows) as it comes: that rest as SH in each object's frame, over what its
  // open lobe gets (so the transfer dotted with it is the share hidden).
  std::vector<float> has_transfer(kMaxEllipsoids, 0.0f);
  std::vector<glm::vec3> ground_light(std::size_t(kMaxEllipsoids) * kTransferCoefficients);
  ShCoeffs rest = room_sh;
  if (rest.order > 0)
    for (const ShadowLight& sl : lights) {
      double y[kTransferCoefficients];
      sh_basis_all(3, glm::dvec3(sl.world_direction), y);
      for (int j = 0; j < kTransferCoefficients; ++j)
        rest.c[std::size_t(j)] -= glm::dvec3(sl.power) * y[j];
    }
  // What the open lobe of an up-facing floor point (object +Y) gets from a light.
  const auto open = [up = sh_cosine_lobe({0.0, 1.0, 0.0}, 3)](const ShCoeffs& l) {
    glm::dvec3 sum(0.0);
    for (std::size_t j = 0; j < up.size(); ++j) sum += l.c[j] * up[j];
    return sum;
  };
  for (int k = 0; k < count && rest.order > 0; ++k) {
    const Caster& c = casters_[std::size_t(k)];
    glActiveTexture(GLenum(GL_TEXTURE0 + kGroundTransferUnit + k));
    glBindTexture(GL_TEXTURE_2D_ARRAY, c.ground_transfer_tex);
    if (!c.ground_tex || !c.ground_transfer_tex) continue;
    const glm::dmat3 r(c.world_from_object);
    ShCoeffs light = sh_rotate(rest, r);
    glm::dvec3 lobe = open(light);
    // A rest the SH cannot tell from nothing (the lights took it all, or ringing): the room's.
    const ShCoeffs room = sh_rotate(room_sh, r);
    const glm::dvec3 room_lobe = open(room);
    if (!(glm::min(lobe.x, glm::min(lobe.y, lobe.z)) > 0.02 * glm::max(room_lobe.x, 1e-12)))
      light = room, lobe = room_lobe;
    if (!(glm::min(lobe.x, glm::min(lobe.y, lobe.z)) > 0.0)) continue;
    has_transfer[std::size_t(k)] = 1.0f;
    for (int j = 0; j < kTransferCoefficients; ++j)
      ground_light[std::size_t(k * kTransferCoefficients + j)] =
          glm::vec3(light.c[std::size_t(j)] / lobe);
  }
  for (int k = count; k < kMaxEllipsoids; ++k) {
    glActiveTexture(GLenum(GL_TEXTURE0 + kGroundTransferUnit + k));
    glBindTexture(GL_TEXTURE_2D_ARRAY, 0);
  }
  glUniform1fv(pr.uniform("u_has_ground_transfer"), kMaxEllipsoids, has_transfer.data());
  glUniform3fv(pr.uniform("u_ground_light"), GLsizei(ground_light.size()),
               glm::value_ptr(ground_light[0]));
}

void ShadowPass::apply_on_gpu(const RenderTargets& targets, const glm::mat4& view_proj, bool rgb,
                              const FullscreenPass& fullscreen) {
  Program& pr = rgb ? apply_rgb_ : apply_;
  if (!pr.id()) {
    pr =
        rgb ? Program(shader_dir_, "shadow_catcher.vert", "shadow_apply.frag", {{"FRAME_RGB", "1"}})
            : Program(shader_dir_, "shadow_catcher.vert", "shadow_apply.frag");
    glUseProgram(pr.id());
    glUniform1i(pr.uniform("u_factors"), 0);
  }
  glUseProgram(pr.id());
  glUniform4fv(pr.uniform("u_rect"), 1, glm::value_ptr(rect_));
  glUniformMatrix4fv(pr.uniform("u_view_proj"), 1, GL_FALSE, glm::value_ptr(view_proj));
  glUniform2f(pr.uniform("u_factor_extent"), float(factor_w_ * kFactorScale),
              float(factor_h_ * kFactorScale));
  glActiveTexture(GL_TEXTURE0);
  glBindTexture(GL_TEXTURE_2D, factor_tex_.id);
  glBindFramebuffer(GL_FRAMEBUFFER, targets.out_fbo.id);
  glViewport(0, 0, targets.w, targets.h);
  glDisable(GL_DEPTH_TEST);
  glDisable(GL_CULL_FACE);
  glEnable(GL_BLEND);
  glBlendFunc(GL_ZERO, GL_SRC_COLOR);  // frame x factor
  fullscreen.draw_rectangle();
  glDisable(GL_BLEND);
  gl::check("shadow catcher (applied on the GPU)");
}

bool ShadowPass::apply_on_cpu(const ImageU8View& frame) {
  // The factors are read back (small) and applied on the CPU over their bounding box:
  // bilinear upsampling (texel centres as GL samples them) and code * factor / 255, exact
  // where the factor is 255.
  factors_.resize(std::size_t(factor_w_) * factor_h_ * 4);
  glPixelStorei(GL_PACK_ALIGNMENT, 4);
  glBindFramebuffer(GL_FRAMEBUFFER, factor_fbo_.id);
  glReadPixels(0, 0, factor_w_, factor_h_, GL_RGBA, GL_UNSIGNED_BYTE, factors_.data());
  gl::check("reading the shadow factors");
  int x0 = factor_w_, y0 = factor_h_, x1 = -1, y1 = -1;
  for (int y = 0; y < factor_h_; ++y)
    for (int x = 0; x < factor_w_; ++x) {
      const std::uint8_t* f = &factors_[(std::size_t(y) * factor_w_ + x) * 4];
      if ((f[0] & f[1] & f[2]) == 255) continue;
      x0 = std::min(x0, x), x1 = std::max(x1, x), y0 = std::min(y0, y), y1 = std::max(y1, y);
    }
  if (x1 < 0) return false;
  // One texel of ones around the box (bilinear reach), then the box in full-resolution pixels.
  x0 = std::max(0, x0 - 1), y0 = std::max(0, y0 - 1);
  x1 = std::min(factor_w_ - 1, x1 + 1), y1 = std::min(factor_h_ - 1, y1 + 1);
  // The frame, with the box's pixels multiplied by the factors upsampled bilinearly (texel
  // centres at (i + 0.5) * scale, clamped at the box's edges: the ring of ones above).
  shadowed_.resize(w_, h_, 3);
  for (int y = 0; y < h_; ++y)
    std::copy(frame.row(y), frame.row(y) + std::size_t(w_) * 3, shadowed_.row(y));
  const int px0 = x0 * kFactorScale, py0 = y0 * kFactorScale;
  const int px1 = std::min(w_, (x1 + 1) * kFactorScale);
  const int py1 = std::min(h_, (y1 + 1) * kFactorScale);
  // Separable: each factor row of the box interpolated across to full resolution once, then
  // every output row between its two factor rows (B, G, R, like the frame).
  const int bw = px1 - px0, rows = y1 - y0 + 1;
  const auto tap = [](int p, int lo, int hi, int& i, float& f) {
    const float s = std::clamp((p + 0.5f) / kFactorScale - 0.5f, float(lo), float(hi));
    i = hi > lo ? std::min(int(s), hi - 1) : lo;
    f = s - float(i);
  };
  across_.resize(std::size_t(rows) * bw * 3);
  taps_.resize(std::size_t(bw));
  weights_.resize(std::size_t(bw));
  for (int x = px0; x < px1; ++x)
    tap(x, x0, x1, taps_[std::size_t(x - px0)], weights_[std::size_t(x - px0)]);
  for (int j = y0; j <= y1; ++j) {
    const std::uint8_t* src = &factors_[std::size_t(j) * factor_w_ * 4];
    float* out = &across_[std::size_t(j - y0) * bw * 3];
    for (int k = 0; k < bw; ++k) {
      const int i = taps_[std::size_t(k)], i1 = std::min(i + 1, x1);
      const float fx = weights_[std::size_t(k)];
      for (int c = 0; c < 3; ++c)
        out[3 * k + c] = src[4 * i + c] + fx * (float(src[4 * i1 + c]) - float(src[4 * i + c]));
    }
  }
  for (int y = py0; y < py1; ++y) {
    int j;
    float fy;
    tap(y, y0, y1, j, fy);
    const float* a = &across_[std::size_t(j - y0) * bw * 3];
    const float* b = &across_[std::size_t(std::min(j + 1, y1) - y0) * bw * 3];
    std::uint8_t* row = shadowed_.row(y) + std::size_t(px0) * 3;
    for (int k = 0; k < bw * 3; ++k) {
      const float f = a[k] + fy * (b[k] - a[k]);
      // code * factor / 255, rounded (< 255.5 since factor <= 255): exact where the factor is 1;
      // no branch, so it vectorises
      row[k] = std::uint8_t(int(float(row[k]) * f * (1.0f / 255.0f) + 0.5f));
    }
  }
  return true;
}

}  // namespace arlight::render
