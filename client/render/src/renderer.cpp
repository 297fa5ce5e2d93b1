// The renderer: orders a frame's passes, the way Filament's FRenderer only orders its frame.
// Each pass owns its state in a file of its own: the room's light (scene_lighting), the
// material pass (ibl_pass), the shadow catcher (shadow_lights, shadow_pass), live glass
// (glass_pass), Reinhard's log-average (tone_mapping), colour matching's statistics
// (colour_statistics) and the composite (composite_pass); fullscreen_pass draws them all.
#include <algorithm>
#include <chrono>
#include <cstring>
#include <glm/gtc/matrix_transform.hpp>
#include <stdexcept>
#include <string>

#include "arlight/render/render.hpp"
#include "colour_statistics.hpp"
#include "composite_pass.hpp"
#include "fullscreen_pass.hpp"
#include "gl.hpp"
#include "ibl_pass.hpp"
#include "live_glass.hpp"
#include "log_luminance.hpp"
#include "scene_lighting.hpp"
#include "shadow_pass.hpp"
#include "textures.hpp"

namespace arlight::render {

namespace {

using Clock = std::chrono::steady_clock;
double ms_since(Clock::time_point t) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t).count();
}

// Throws GlError unless the current context is ES 3 with float colour targets.
void check_context() {
  if (!glGetString(GL_VERSION)) throw GlError("Renderer: no current OpenGL ES context");
  GLint major = 0;
  glGetIntegerv(GL_MAJOR_VERSION, &major);
  if (major < 3)
    throw GlError("Renderer: needs OpenGL ES 3, the context is " +
                  std::string(reinterpret_cast<const char*>(glGetString(GL_VERSION))));
  GLint n_ext = 0;
  glGetIntegerv(GL_NUM_EXTENSIONS, &n_ext);
  for (GLint i = 0; i < n_ext; ++i)
    if (std::string_view(reinterpret_cast<const char*>(glGetStringi(GL_EXTENSIONS, GLuint(i)))) ==
        "GL_EXT_color_buffer_float")
      return;
  throw GlError(
      "Renderer: OpenGL ES extension GL_EXT_color_buffer_float is missing (needed for the "
      "RGBA16F HDR target)");
}

}  // namespace

const char* shading_name(Shading shading) {
  switch (shading) {
    case Shading::ImageBased:
      return "maps";
    case Shading::Hemisphere:
      return "hemisphere";
    case Shading::HemisphereOcclusion:
      return "hemisphere-occlusion";
  }
  return "?";
}

std::optional<Shading> shading_named(std::string_view name) {
  for (Shading s : {Shading::ImageBased, Shading::Hemisphere, Shading::HemisphereOcclusion})
    if (name == shading_name(s)) return s;
  return std::nullopt;
}

const char* refraction_name(Refraction refraction) {
  return refraction == Refraction::LiveFrame ? "live" : "maps";
}

std::optional<Refraction> refraction_named(std::string_view name) {
  for (Refraction r : {Refraction::Maps, Refraction::LiveFrame})
    if (name == refraction_name(r)) return r;
  return std::nullopt;
}

glm::mat4 projection_from_intrinsics(const CameraIntrinsics& k, int width, int height, float n,
                                     float f) {
  if (k.width <= 0 || k.height <= 0 || !(k.fx > 0) || !(k.fy > 0))
    throw std::invalid_argument(
        "projection_from_intrinsics: intrinsics need a size and fx, fy > 0");
  if (!(n > 0) || !(f > n))
    throw std::invalid_argument("projection_from_intrinsics: need 0 < near < far");
  // Scale to the viewport; pixel edges (not centres) scale: (c + 0.5) * s - 0.5.
  const double sx = double(width) / k.width, sy = double(height) / k.height;
  const double fx = k.fx * sx, fy = k.fy * sy;
  const double cx = (k.cx + 0.5) * sx - 0.5, cy = (k.cy + 0.5) * sy - 0.5;
  // A camera point (x, y, z), z < 0, lands at OpenCV pixel u = fx x / -z + cx, v = -fy y / -z + cy;
  // window coordinates are pixel + 0.5 and the target's row 0 is the image's top row, so
  // ndc = 2 (pixel + 0.5) / size - 1 on both axes, times clip w = -z.
  glm::mat4 p(0.0f);
  p[0][0] = float(2.0 * fx / width);
  p[2][0] = float(1.0 - 2.0 * (cx + 0.5) / width);
  p[1][1] = float(-2.0 * fy / height);
  p[2][1] = float(1.0 - 2.0 * (cy + 0.5) / height);
  p[2][2] = -(f + n) / (f - n);
  p[3][2] = -2.0f * f * n / (f - n);
  p[2][3] = -1.0f;
  return p;
}

struct Renderer::Impl {
  Impl(int width, int height, const std::filesystem::path& shader_dir)
      : ibl(shader_dir),
        log_luminance(shader_dir, width, height),
        composite(shader_dir),
        targets(width, height),
        shadow(shader_dir, width, height),
        colour(shader_dir) {
    upload_response_lut(CameraResponse::srgb(), response_lut);
    upload_response_inverse(CameraResponse::srgb(), response_inverse);
    glBindFramebuffer(GL_FRAMEBUFFER, 0);
    gl::check("creating the renderer");
  }

  Clock::time_point frame_start = Clock::now();
  // Made in this order: shader errors show up at construction, the common variants' first.
  IblPass ibl;
  LogLuminance log_luminance;
  CompositePass composite;
  FullscreenPass fullscreen;
  RenderTargets targets;
  SceneLighting lighting;
  ShadowPass shadow;
  LiveGlass glass;
  ColourStatistics colour;
  gl::Texture response_lut, response_inverse;  // the camera response (set_response)

  glm::mat4 view_proj{1.0f};
  glm::vec3 camera_position{0.0f};
  glm::mat3 world_from_scene{1.0f};
  Refraction refraction = Refraction::Maps;

  FrameTimings timings;
  std::vector<std::uint8_t> rgba;  // readback buffer
  bool composited = false;
  // Alpha-blended surfaces were drawn this frame (and, before the first, radiance zeroed where
  // nothing was drawn).
  bool uncovered_cleared = false;
  bool frame_rgb = false;  // what the last composite left in the output

  DrawState draw_state() const { return {view_proj, camera_position, world_from_scene}; }
  Clock::time_point begin_composite(const ToneMapping& tone, bool wait);
  void upload_frame(const ImageU8View& camera);
  void tone_map_and_composite(const ToneMapping& tone, bool rgb);
  void read_output(std::span<std::uint8_t> out);
};

Renderer::Renderer(int width, int height, const std::filesystem::path& shader_dir) {
  if (width < 1 || height < 1) throw std::invalid_argument("Renderer: size must be positive");
  check_context();
  p_ = std::make_unique<Impl>(width, height, shader_dir);
}

Renderer::~Renderer() = default;

int Renderer::width() const { return p_->targets.w; }
int Renderer::height() const { return p_->targets.h; }

void Renderer::set_sh(const ShCoeffs& sh) { p_->lighting.set_sh(sh); }

void Renderer::set_maps(const std::vector<double>& shininess, const std::vector<EnvMap>& maps) {
  p_->lighting.set_maps(shininess, maps);
}

void Renderer::clear_maps() { p_->lighting.clear_maps(); }

void Renderer::set_ggx_chain(const std::vector<EnvMap>& levels, const std::vector<double>& roughness,
                             const std::vector<SpecularLight>& lights) {
  p_->lighting.set_ggx_chain(levels, roughness, lights);
}

void Renderer::clear_ggx_chain() { p_->lighting.clear_ggx_chain(); }
bool Renderer::has_ggx_chain() const { return p_->lighting.ggx_levels() > 0; }

void Renderer::set_shadow(const ShadowSettings& settings) { p_->shadow.set_settings(settings); }

const ShadowSettings& Renderer::shadow() const { return p_->shadow.settings(); }

float Renderer::shadow_fraction() const {
  return p_->shadow.fraction(p_->lighting, p_->world_from_scene);
}

LightingSource Renderer::lighting_source() const { return p_->lighting.source(); }

void Renderer::set_reflection_lookup(ReflectionLookup lookup) { p_->ibl.lookup = lookup; }

void Renderer::set_shading(Shading shading) { p_->ibl.shading = shading; }

Shading Renderer::shading() const { return p_->ibl.shading; }

void Renderer::set_refraction(Refraction refraction) { p_->refraction = refraction; }

Refraction Renderer::refraction() const { return p_->refraction; }

HemispherePriors Renderer::hemisphere_priors() const { return p_->lighting.hemisphere_priors(); }

EnvironmentPriors Renderer::environment_priors() const { return p_->lighting.environment_priors(); }

void Renderer::set_environment_priors(std::optional<EnvironmentPriors> priors) {
  p_->lighting.set_environment_priors(priors);
}

void Renderer::set_camera(const CameraIntrinsics& k, const glm::dmat4& camera_from_scene,
                          float near_plane, float far_plane) {
  const glm::mat4 proj =
      projection_from_intrinsics(k, p_->targets.w, p_->targets.h, near_plane, far_plane);
  p_->view_proj = proj * glm::mat4(camera_from_scene);
  p_->camera_position = glm::vec3(glm::inverse(camera_from_scene) * glm::dvec4(0, 0, 0, 1));
}

void Renderer::set_world_from_scene(const glm::dquat& q) {
  p_->world_from_scene = glm::mat3(glm::mat3_cast(glm::normalize(q)));
}

void Renderer::set_world_from_scene(const glm::dmat3& r) { p_->world_from_scene = glm::mat3(r); }

void Renderer::set_response(const CameraResponse& response) {
  upload_response_lut(response, p_->response_lut);
  upload_response_inverse(response, p_->response_inverse);
}

void Renderer::begin_frame() {
  Impl& p = *p_;
  p.frame_start = Clock::now();
  p.composited = false;
  p.shadow.begin_frame();
  p.glass.begin_frame();
  glBindFramebuffer(GL_FRAMEBUFFER, p.targets.hdr_fbo.id);
  glViewport(0, 0, p.targets.w, p.targets.h);
  const float zero[4] = {0, 0, 0, 0};
  // The mask; radiance stays (read only where masked; before alpha-blended surfaces are drawn
  // over it, IblPass::clear_uncovered zeroes it where nothing is: 2 ms a frame at 1280 x 720 on
  // llvmpipe saved for the frames without them).
  glClearBufferfv(GL_COLOR, 1, zero);
  p.uncovered_cleared = false;
  glClearBufferfi(GL_DEPTH_STENCIL, 0, 1.0f, 0);
}

void Renderer::draw(const GpuMesh& mesh, const Material& m, const glm::mat4& model) {
  draw(mesh, {}, m, model);
}

void Renderer::draw(const GpuMesh& mesh, std::span<const Material> materials,
                    const Material& fallback, const glm::mat4& model) {
  Impl& p = *p_;
  const auto material_of = [&](const MeshPart& part) -> const Material& {
    return part.material >= 0 && std::size_t(part.material) < materials.size()
               ? materials[std::size_t(part.material)]
               : fallback;
  };
  const auto blended = [](const Material& m) { return m.pbr && m.pbr->alpha_blend; };
  for (const MeshPart& part : mesh.parts()) {  // the opaque parts, then the blended ones over them
    const Material& m = material_of(part);
    if (blended(m)) continue;
    if (m.transmissive() && p.refraction == Refraction::LiveFrame)
      p.glass.defer(mesh, m, model, p.draw_state(), part);
    else
      p.ibl.draw(mesh, m, model, p.draw_state(), p.lighting, p.targets, part);
  }
  for (const MeshPart& part : mesh.parts()) {
    if (!blended(material_of(part))) continue;
    if (!p.uncovered_cleared) p.ibl.clear_uncovered(p.targets, p.fullscreen);
    p.uncovered_cleared = true;
    p.ibl.draw(mesh, material_of(part), model, p.draw_state(), p.lighting, p.targets, part);
  }
  p.shadow.add_caster(mesh, model, p.world_from_scene);
}

void Renderer::composite(const ImageU8View& frame, const ToneMapping& tone, ImageU8& out) {
  out.resize(p_->targets.w, p_->targets.h, 3);
  composite(frame, tone, std::span(out.data(), std::size_t(p_->targets.w) * p_->targets.h * 3));
}

void Renderer::composite(const ImageU8View& frame, const ToneMapping& tone,
                         std::span<std::uint8_t> out) {
  Impl& p = *p_;
  const int w = p.targets.w, h = p.targets.h;
  if (!frame.data || frame.channels != 3 || frame.width != w || frame.height != h ||
      frame.stride < std::ptrdiff_t(w) * 3)
    throw std::invalid_argument("composite: the camera frame must be 8-bit BGR of " +
                                std::to_string(w) + "x" + std::to_string(h));
  if (out.size() != std::size_t(w) * h * 3)
    throw std::invalid_argument("composite: the output must hold " + std::to_string(w) + "x" +
                                std::to_string(h) + "x3 bytes");
  const auto t0 = p.begin_composite(tone, /*wait=*/true);

  // Shadows on the floor: the factors at low resolution on the GPU, multiplied into a copy of
  // the frame where they are below 1 (before the upload; the objects' pixels get darkened too,
  // but the composite pass overwrites every one of them).
  p.timings.shadow_ms = 0, p.timings.shadow_lights = 0;
  ImageU8View camera = frame;
  if (p.shadow.active()) {
    const auto ts = Clock::now();
    if (p.shadow.draw_factors(p.draw_state(), p.lighting, p.response_lut.id, p.fullscreen,
                              p.timings.shadow_lights) &&
        p.shadow.apply_on_cpu(frame))
      camera = p.shadow.shadowed().view();
    p.timings.shadow_ms = ms_since(ts);
  }
  p.upload_frame(camera);
  p.timings.refraction_ms = 0;  // a glass draw that throws leaves no stale figure
  p.timings.refraction_ms =
      p.glass.draw(p.targets, tone, false, p.ibl, p.lighting, p.response_inverse.id);
  p.tone_map_and_composite(tone, false);
  p.timings.tonemap_ms = ms_since(t0);
  p.composited = true;
  const auto t1 = Clock::now();
  p.read_output(out);
  p.timings.readback_ms = ms_since(t1);
}

unsigned Renderer::camera_texture() const { return p_->targets.out_tex.id; }

void Renderer::composite_in_place(const ToneMapping& tone) {
  Impl& p = *p_;
  // No glFinish: in a browser it is a round trip to the GPU process that stalls the page (the
  // timings are then the time to issue the frame, not to draw it).
  const auto t0 = p.begin_composite(tone, /*wait=*/false);
  p.timings.shadow_ms = 0, p.timings.shadow_lights = 0;
  if (p.shadow.active()) {
    const auto ts = Clock::now();
    if (p.shadow.draw_factors(p.draw_state(), p.lighting, p.response_lut.id, p.fullscreen,
                              p.timings.shadow_lights))
      p.shadow.apply_on_gpu(p.targets, p.view_proj, true, p.fullscreen);
    p.timings.shadow_ms = ms_since(ts);
  }
  p.timings.refraction_ms = 0;  // a glass draw that throws leaves no stale figure
  p.timings.refraction_ms =
      p.glass.draw(p.targets, tone, true, p.ibl, p.lighting, p.response_inverse.id);
  p.tone_map_and_composite(tone, true);
  p.timings.tonemap_ms = ms_since(t0);
  p.timings.readback_ms = 0;
  p.composited = true;
}

// Checks the tone mapping, ends the render timing (after the GPU finished, with `wait`) and sets
// the state the full-screen passes need; the start of the compositing's timing.
Clock::time_point Renderer::Impl::begin_composite(const ToneMapping& tone, bool wait) {
  if (!(tone.exposure > 0) || !(tone.gain > 0) || !(tone.key > 0) || !(tone.white > 0))
    throw std::invalid_argument("composite: exposure, gain, key and white must be positive");
  if (wait) glFinish();
  timings.render_ms = ms_since(frame_start);
  const auto t0 = Clock::now();
  glDisable(GL_DEPTH_TEST);
  glDisable(GL_BLEND);
  glDisable(GL_CULL_FACE);
  return t0;
}

// The camera frame, in place, straight into the output (BGR bytes in an RGB8 texture).
void Renderer::Impl::upload_frame(const ImageU8View& camera) {
  const int w = targets.w, h = targets.h;
  glActiveTexture(GL_TEXTURE1);
  glBindTexture(GL_TEXTURE_2D, targets.out_tex.id);
  glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
  if (camera.stride % 3 == 0) {  // rows a whole number of pixels apart: one upload
    glPixelStorei(GL_UNPACK_ROW_LENGTH, GLint(camera.stride / 3));
    glTexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, w, h, GL_RGB, GL_UNSIGNED_BYTE, camera.data);
  } else {
    glPixelStorei(GL_UNPACK_ROW_LENGTH, 0);
    for (int y = 0; y < h; ++y)
      glTexSubImage2D(GL_TEXTURE_2D, 0, 0, y, w, 1, GL_RGB, GL_UNSIGNED_BYTE, camera.row(y));
  }
  glPixelStorei(GL_UNPACK_ROW_LENGTH, 0);
  glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
  glBindTexture(GL_TEXTURE_2D, 0);
}

// Reinhard's log-average (when asked), colour matching's statistics (when asked) and the
// composite of the objects' pixels into the output, whose other pixels hold the camera frame.
void Renderer::Impl::tone_map_and_composite(const ToneMapping& tone, bool rgb) {
  frame_rgb = rgb;
  if (tone.mode == ToneMode::Reinhard) log_luminance.reduce(targets, fullscreen);
  if (tone.colour == ColourCorrection::Match)
    colour.measure(targets, float(tone.exposure * tone.gain), fullscreen);
  composite.draw(targets, tone, rgb,
                 {response_lut.id, log_luminance.sum_texture(), &colour, &lighting,
                  uncovered_cleared},
                 fullscreen);
  if (!rgb) glFinish();  // composite() times the pass; the browser's path does not wait for it
}

// The output read back as packed B, G, R.
void Renderer::Impl::read_output(std::span<std::uint8_t> out) {
  // The texture holds B, G, R: dropping alpha gives OpenCV's BGR. (Reading GL_RGB directly,
  // where the implementation offers it, was slower on Mesa: it converts per pixel.)
  const std::size_t pixels = std::size_t(targets.w) * targets.h;
  rgba.resize(pixels * 4);
  glPixelStorei(GL_PACK_ALIGNMENT, 4);
  glReadPixels(0, 0, targets.w, targets.h, GL_RGBA, GL_UNSIGNED_BYTE, rgba.data());
  gl::check("reading the composited frame");
  // One 4-byte store per pixel, each overwriting the previous one's spare byte; the last pixel
  // copies its 3 bytes alone.
  for (std::size_t i = 0; i + 1 < pixels; ++i) std::memcpy(&out[3 * i], &rgba[4 * i], 4);
  std::memcpy(&out[3 * (pixels - 1)], &rgba[4 * (pixels - 1)], 3);
}

void Renderer::present() {
  if (!p_->composited) return;
  p_->composite.present(p_->targets, p_->frame_rgb, p_->fullscreen);
}

const FrameTimings& Renderer::timings() const { return p_->timings; }

HdrReadback Renderer::read_hdr() {
  Impl& p = *p_;
  const int w = p.targets.w, h = p.targets.h;
  std::vector<float> px(std::size_t(w) * h * 4);
  std::vector<std::uint8_t> mask(std::size_t(w) * h * 4);
  glBindFramebuffer(GL_READ_FRAMEBUFFER, p.targets.hdr_fbo.id);
  glPixelStorei(GL_PACK_ALIGNMENT, 4);
  glReadBuffer(GL_COLOR_ATTACHMENT0);
  glReadPixels(0, 0, w, h, GL_RGBA, GL_FLOAT, px.data());
  glReadBuffer(GL_COLOR_ATTACHMENT1);
  glReadPixels(0, 0, w, h, GL_RGBA, GL_UNSIGNED_BYTE, mask.data());
  glReadBuffer(GL_COLOR_ATTACHMENT0);
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
  gl::check("reading the HDR target");
  HdrReadback r{Image(w, h), std::vector<std::uint8_t>(std::size_t(w) * h)};
  for (std::size_t i = 0; i < r.mask.size(); ++i) {
    r.mask[i] = mask[4 * i] > 127 ? 1 : 0;
    if (!r.mask[i]) continue;  // stale radiance from earlier frames: report 0
    for (std::size_t c = 0; c < 3; ++c) r.radiance.storage()[3 * i + c] = px[4 * i + c];
  }
  return r;
}

float Renderer::last_log_average() const { return p_->log_luminance.log_average(); }

}  // namespace arlight::render
