#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstring>
#include <glm/gtc/matrix_inverse.hpp>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/type_ptr.hpp>
#include <limits>
#include <numbers>
#include <optional>
#include <stdexcept>
#include <string>
#include <unordered_map>

#include "arlight/light_sources.hpp"
#include "arlight/render.hpp"
#include "gl.hpp"
#include "textures.hpp"

namespace arlight::render {

namespace {

using Clock = std::chrono::steady_clock;
double ms_since(Clock::time_point t) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t).count();
}

constexpr int kReduceBlock = 8;                            // loglum_reduce.frag's BLOCK
constexpr int kColourStep = 2;  // colour matching measures every 2nd pixel across and down
constexpr int kShMapSize = 32;                             // SH maps: 64 x 32 lat-long
const std::vector<double> kShShininess = {1, 8, 32, 128};  // SH maps' lobes

// Texture units.
enum Unit : GLint { kIrr = 0, kRefl0, kRefl1, kAlbedo, kNormal, kLight, kFrame, kResponseInverse };

constexpr int kMaxEllipsoids = 4;  // shadow_catcher.frag's u_centre / u_inv_axes / u_ground*
constexpr int kGroundUnit = 3;     // the catcher's texture units of u_ground0..3
constexpr int kGroundTransferUnit = 7;  // ... and of u_ground_transfer0..3
constexpr int kFactorScale = 4;    // shadow factors at 1/4 of the output's width and height

// A mesh drawn this frame, for the shadow pass (its scene-frame bounds and what draws it).
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

// An object's rotation into the lighting's (world) frame: the model's scale taken out.
glm::mat3 world_from_object(const glm::mat3& world_from_scene, const glm::mat4& model) {
  glm::mat3 r = world_from_scene * glm::mat3(model);
  for (int k = 0; k < 3; ++k) r[k] = glm::normalize(r[k]);
  return r;
}

// A set of environment maps of one projection, sorted by shininess.
struct EnvSet {
  Projection projection = Projection::LatLong;
  std::vector<double> shininess;
  std::vector<gl::Texture> tex;
  std::vector<glm::ivec2> size;
  bool empty() const { return tex.empty(); }

  // Uploads maps (sorted by shininess), re-using textures of the same count and sizes.
  void upload(const std::vector<double>& s, const std::vector<EnvMap>& maps) {
    std::vector<std::size_t> order(s.size());
    for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
    std::sort(order.begin(), order.end(), [&](auto a, auto b) { return s[a] < s[b]; });
    if (tex.size() != maps.size() || projection != maps[0].layout.projection()) {
      tex.clear(), size.clear();
      tex.resize(maps.size()), size.resize(maps.size(), glm::ivec2(0));
    }
    projection = maps[0].layout.projection();
    shininess.clear();
    for (std::size_t k = 0; k < order.size(); ++k) {
      shininess.push_back(s[order[k]]);
      upload_env(maps[order[k]], tex[k], size[k].x, size[k].y);
    }
  }

  // The two maps around shininess s and the weight of the second (log-shininess interpolation),
  // or the nearest one (weight 0).
  std::tuple<std::size_t, std::size_t, float> pick(double s, ReflectionLookup lookup) const {
    const std::size_t n = shininess.size();
    if (s <= shininess.front()) return {0, 0, 0.0f};
    if (s >= shininess.back()) return {n - 1, n - 1, 0.0f};
    std::size_t i = 0;
    while (i + 1 < n && shininess[i + 1] <= s) ++i;
    if (shininess[i] == s) return {i, i, 0.0f};
    const double t = (std::log(s) - std::log(shininess[i])) /
                     (std::log(shininess[i + 1]) - std::log(shininess[i]));
    if (lookup == ReflectionLookup::Nearest)
      return t < 0.5 ? std::tuple{i, i, 0.0f} : std::tuple{i + 1, i + 1, 0.0f};
    return {i, i + 1, float(t)};
  }
};

// Features of an ibl.frag variant (bits of its cache key, above the projection's 2 bits).
enum Feature : unsigned {
  kDiffuse = 1,
  kAlbedoMap = 2,
  kNormalMap = 4,
  kLightMap = 8,
  kSpecular = 16,
  kMix = 32,
  kHemisphere = 64,       // eq. 6 instead of the maps (Shading::Hemisphere*)
  kGlass = 128,           // a transmissive material (Material::transmission)
  kLiveRefraction = 256,  // ... showing the camera frame (Refraction::LiveFrame)
  kFrameRgb = 512,        // ... whose copy holds R, G, B (the browser's), not B, G, R
  kTransfer = 1024,       // the mesh's SH-9 transfer dotted with the room's SH (not hemisphere)
};

// What draw() took from the renderer's state for a draw it defers to composite().
struct DrawState {
  glm::mat4 view_proj;
  glm::vec3 camera_position;
  glm::mat3 world_from_scene;
};

// Glass under Refraction::LiveFrame, drawn in composite() once the frame is there.
struct DeferredDraw {
  const GpuMesh* mesh;
  Material material;
  glm::mat4 model;
  DrawState state;
};

constexpr int kHorizontalNormals = 16;  // HemispherePriors' light and shadow

struct IblProgram {
  Program program;
  GLint model = -1, normal_matrix = -1, view_proj = -1, reflection_mix = -1, camera_position = -1,
        world_from_scene = -1, kd = -1, ks = -1, normal_strength = -1, sky = -1, ground = -1,
        occlusion = -1, ior = -1, transmission = -1, object_from_scene = -1, ellipsoid_centre = -1,
        ellipsoid_axes = -1, inv_exposure_gain = -1, light_sh = -1;
};

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
  int w, h;
  std::filesystem::path shader_dir;
  std::unordered_map<unsigned, IblProgram> ibl;  // by projection | features << 2, made lazily
  Program reduce_first, reduce, present;
  // composite.frag by ToneMode | ColourCorrection << 2 | (a frame stored R, G, B, as
  // composite_in_place has it) << 4, made when first used.
  std::unordered_map<unsigned, Program> composites;
  const Program& composite_program(int mode, ColourCorrection colour, bool rgb);
  Program present_rgb;
  bool frame_rgb = false;  // what the last composite left in the output
  Clock::time_point begin_composite(const ToneMapping& tone, bool wait);
  void tone_map_and_composite(const ToneMapping& tone, bool rgb);
  GLuint empty_vao = 0;

  gl::Framebuffer hdr_fbo, out_fbo;
  gl::Texture hdr_tex, mask_tex, out_tex, response_lut, response_inverse, white_tex,
      flat_normal_tex;
  gl::Renderbuffer depth;
  struct Level {
    gl::Framebuffer fbo;
    gl::Texture tex;
    int w, h;
  };
  std::vector<Level> levels;  // the log-luminance reduction chain, down to 1x1
  // Colour matching's statistics of the virtual pixels (colour_stats_reduce.frag), made when
  // first used: sums and sums of squares, down to 1x1.
  struct ColourLevel {
    gl::Framebuffer fbo;
    gl::Texture sum, sum2;
    int w, h;
  };
  std::vector<ColourLevel> colour_levels;
  Program colour_first, colour_reduce;
  void measure_colour(const ToneMapping& tone);
  // The room's colour priors (dissertation §5.1) from the live SH or the map set's sharpest map,
  // made when first asked for (a colour correction): the page must not spend its frame time on
  // them with every LightingUpdate.
  mutable std::optional<EnvironmentPriors> sh_priors, map_priors;
  std::optional<EnvironmentPriors> priors_override;
  std::optional<EnvMap> sharpest_map;
  const EnvironmentPriors& environment_priors() const {
    if (priors_override) return *priors_override;
    if (!maps.empty()) {
      if (!map_priors) map_priors = render::environment_priors(*sharpest_map);
      return *map_priors;
    }
    if (!sh_priors) {
      const EnvLayout layout = EnvLayout::for_size(Projection::LatLong, kShMapSize);
      Image radiance = last_sh.order > 0 ? sh_reconstruct(last_sh, layout)
                                         : Image(layout.width(), layout.height());
      for (float& v : radiance.storage()) v = std::max(v, 0.0f);
      sh_priors = render::environment_priors(EnvMap(layout, std::move(radiance)));
    }
    return *sh_priors;
  }

  EnvSet maps, sh_maps, black;
  ShCoeffs last_sh;
  // The room's radiance SH, bands 0-2 (world frame), for the meshes' transfer: the sharpest map's
  // under a map set (nearest the radiance), else the live SH's; order 0 before any lighting.
  ShCoeffs room_sh;
  void set_room_sh(const ShCoeffs& sh) {
    room_sh = ShCoeffs(3);
    for (int k = 0; k < std::min(sh_count(3), int(sh.c.size())); ++k)
      room_sh.c[std::size_t(k)] = sh.c[std::size_t(k)];
  }
  ReflectionLookup lookup = ReflectionLookup::Interpolate;

  glm::mat4 view_proj{1.0f};
  glm::vec3 camera_position{0.0f};
  glm::mat3 world_from_scene{1.0f};

  struct CachedTexture {
    std::weak_ptr<const TextureImage> owner;
    gl::Texture tex;
  };
  std::unordered_map<const TextureImage*, CachedTexture> textures;

  // Shadows (ShadowSettings): settings, this frame's casters, the shadow map, the programs and
  // the irradiance for f (the irradiance SH of the live SH; a copy of the irradiance map).
  ShadowSettings shadow;
  std::vector<Caster> casters;
  gl::Texture shadow_tex, factor_tex;  // shadow_tex: one depth layer per light
  gl::Framebuffer shadow_fbo, factor_fbo;
  int shadow_size = 0, shadow_layers = 0, factor_w = 0, factor_h = 0;
  std::vector<float> shadow_key;
  std::vector<std::uint8_t> factors;  // the low-resolution factors, read back  // what the shadow
                                      // map holds (light, casters); empty: nothing
  Program shadow_depth, shadow_catcher;
  ShCoeffs irradiance_sh;
  // The irradiance map's bands 0-2 (irradiance is smooth: they hold nearly all of it), so a
  // value at any direction is smooth too, not the nearest texel's.
  std::optional<ShCoeffs> irradiance_map_sh;

  // Lbar(n) = irradiance / pi at world direction n from the current lighting (0 without).
  glm::vec3 irradiance_over_pi(glm::vec3 n) const {
    if (irradiance_map_sh) return glm::vec3(sh_evaluate(*irradiance_map_sh, glm::dvec3(n)));
    if (!sh_maps.empty() && irradiance_sh.order > 0)
      return glm::vec3(sh_evaluate(irradiance_sh, glm::dvec3(n)));
    return glm::vec3(0.0f);
  }

  // The dominant light's f (ShadowSettings), for lighting without a map set.
  float dominant_fraction() const {
    if (!shadow.enabled) return 0.0f;
    const glm::vec3 up = world_from_scene * glm::vec3(0, 0, 1);
    const float len = glm::length(shadow.light_direction);
    if (!(len > 0)) return 0.0f;
    const float cos_l = std::max(0.0f, glm::dot(shadow.light_direction / len, up));
    const float e_dom = luminance(shadow.light_colour) * cos_l;
    if (!(e_dom > 0)) return 0.0f;
    const float e_tot = std::numbers::pi_v<float> * luminance(irradiance_over_pi(up));
    const float f = e_tot > 0 ? e_dom / e_tot : 1.0f;
    return std::clamp(f, 0.0f, std::clamp(shadow.max_fraction, 0.0f, 1.0f));
  }

  // The map set's light clusters (tutorial §6), built for the floor's normal (rebuilt when it
  // turns by more than ~2 degrees) and the source share they were asked for.
  mutable std::optional<LightTree> light_tree;
  mutable float light_tree_share = 0;
  struct ShadowLight {
    glm::vec3 direction;  // unit, scene frame, above the floor
    float fraction;       // its f_i: share of the floor's irradiance
    glm::vec3 world_direction;
    glm::vec3 power;  // radiance x solid angle (RGB): its SH is power Y_lm(world_direction)
  };
  // The hard shadows this frame blends: the chosen clusters under a map set, else the dominant
  // light; their fractions sum to at most max_fraction.
  std::vector<ShadowLight> shadow_lights() const {
    std::vector<ShadowLight> lights;
    if (!shadow.enabled) return lights;
    const glm::mat3 scene_from_world = glm::transpose(world_from_scene);
    const glm::vec3 up = world_from_scene * glm::vec3(0, 0, 1);
    const auto add = [&](glm::vec3 world_direction, float f, glm::vec3 power) {
      const glm::vec3 l = glm::normalize(scene_from_world * world_direction);
      if (f > 0.0f && l.z > 0.02f) lights.push_back({l, f, glm::normalize(world_direction), power});
    };
    if (sharpest_map) {
      if (!light_tree || light_tree_share != shadow.source_share ||
          glm::dot(light_tree->normal, up) < 0.9994f) {
        LightTreeOptions o;
        o.power_share = std::clamp(double(shadow.source_share), 0.01, 1.0);
        o.max_leaves = kMaxShadowLights;
        light_tree = build_light_tree(*sharpest_map, glm::dvec3(up), o);
        light_tree_share = shadow.source_share;
      }
      const float total = luminance(light_tree->receiver_irradiance);
      for (const int i :
           select_lights(*light_tree, std::clamp(shadow.lights, 1, kMaxShadowLights))) {
        const LightCluster& c = light_tree->nodes[std::size_t(i)];
        if (total > 0.0f && c.spread <= shadow.max_spread)
          add(c.direction, luminance(c.irradiance) / total,
              c.irradiance / std::max(glm::dot(c.direction, up), 0.05f));
      }
    } else if (glm::length(shadow.light_direction) > 0.0f) {
      add(shadow.light_direction, dominant_fraction(), shadow.light_colour);
    }
    float sum = 0.0f;
    for (const ShadowLight& l : lights) sum += l.fraction;
    const float cap = std::clamp(shadow.max_fraction, 0.0f, 1.0f);
    if (sum > cap)
      for (ShadowLight& l : lights) l.fraction *= cap / sum, l.power *= cap / sum;
    return lights;
  }
  float shadow_fraction() const {
    float sum = 0.0f;
    for (const ShadowLight& l : shadow_lights()) sum += l.fraction;
    return sum;
  }

  Shading shading = Shading::ImageBased;
  Refraction refraction = Refraction::Maps;
  std::vector<DeferredDraw> live_glass;  // this frame's, for composite()
  gl::Texture frame_copy;                // what live glass samples: the output can't be both
  DrawState draw_state() const { return {view_proj, camera_position, world_from_scene}; }
  // Binds everything a draw needs and draws; `live` = kLiveRefraction (| kFrameRgb) for the
  // deferred glass, with the frame's 1 / (exposure x gain).
  void issue(const GpuMesh& mesh, const Material& m, const glm::mat4& model, const DrawState& st,
             unsigned live, float inv_exposure_gain);
  // The frame in the output copied for the live glass, which is then drawn into the HDR target.
  void draw_live_glass(const ToneMapping& tone, bool rgb);

  HemispherePriors hemisphere_priors() const {
    HemispherePriors h;
    h.upper = irradiance_over_pi({0.0f, 1.0f, 0.0f});
    h.lower = irradiance_over_pi({0.0f, -1.0f, 0.0f});
    h.light = 0.0f, h.shadow = std::numeric_limits<float>::max();
    for (int i = 0; i < kHorizontalNormals; ++i) {
      const float phi = 2.0f * std::numbers::pi_v<float> * float(i) / kHorizontalNormals;
      const float l = luminance(irradiance_over_pi({std::cos(phi), 0.0f, std::sin(phi)}));
      h.light = std::max(h.light, l), h.shadow = std::min(h.shadow, l);
    }
    return h;
  }

  void ensure_shadow_resources(int layers) {
    if (!shadow_depth.id()) {
      shadow_depth = Program(shader_dir, "shadow_depth.vert", "shadow_depth.frag");
      shadow_catcher = Program(shader_dir, "shadow_catcher.vert", "shadow_catcher.frag");
      glUseProgram(shadow_catcher.id());
      glUniform1i(shadow_catcher.uniform("u_shadow_maps"), 0);
      glUniform1i(shadow_catcher.uniform("u_response"), 2);
      for (int k = 0; k < kMaxEllipsoids; ++k) {
        glUniform1i(shadow_catcher.uniform(("u_ground" + std::to_string(k)).c_str()),
                    kGroundUnit + k);
        glUniform1i(shadow_catcher.uniform(("u_ground_transfer" + std::to_string(k)).c_str()),
                    kGroundTransferUnit + k);
      }
      // The factors at 1/kFactorScale of the output's resolution (shadows are smooth).
      factor_w = (w + kFactorScale - 1) / kFactorScale,
      factor_h = (h + kFactorScale - 1) / kFactorScale;
      factor_tex.create();
      glBindTexture(GL_TEXTURE_2D, factor_tex.id);
      glTexImage2D(GL_TEXTURE_2D, 0, GL_RGBA8, factor_w, factor_h, 0, GL_RGBA, GL_UNSIGNED_BYTE,
                   nullptr);
      gl::set_sampling(GL_TEXTURE_2D, GL_LINEAR, GL_CLAMP_TO_EDGE, GL_CLAMP_TO_EDGE);
      glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAX_LEVEL, 0);
      factor_fbo.create();
      glBindFramebuffer(GL_FRAMEBUFFER, factor_fbo.id);
      glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, factor_tex.id, 0);
      gl::check_framebuffer("shadow factors (RGBA8)");
    }
    // One depth layer per light, grown as more lights are asked for.
    const int n = std::max(16, shadow.map_size);
    layers = std::max(layers, 1);
    if (shadow_size == n && shadow_layers >= layers) return;
    shadow_size = n, shadow_layers = std::max(layers, shadow_layers);
    shadow_key.clear();
    shadow_tex = gl::Texture();
    shadow_tex.create();
    glBindTexture(GL_TEXTURE_2D_ARRAY, shadow_tex.id);
    glTexImage3D(GL_TEXTURE_2D_ARRAY, 0, GL_DEPTH_COMPONENT24, n, n, shadow_layers, 0,
                 GL_DEPTH_COMPONENT, GL_UNSIGNED_INT, nullptr);
    gl::set_sampling(GL_TEXTURE_2D_ARRAY, GL_LINEAR, GL_CLAMP_TO_EDGE, GL_CLAMP_TO_EDGE);
    glTexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_MAX_LEVEL, 0);
    glTexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_COMPARE_MODE, GL_COMPARE_REF_TO_TEXTURE);
    glTexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_COMPARE_FUNC, GL_LEQUAL);
    if (!shadow_fbo.id) shadow_fbo.create();
    glBindFramebuffer(GL_FRAMEBUFFER, shadow_fbo.id);
    glFramebufferTextureLayer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, shadow_tex.id, 0, 0);
    const GLenum none = GL_NONE;
    glDrawBuffers(1, &none);
    gl::check_framebuffer("shadow maps (DEPTH_COMPONENT24 layers)");
  }

  // The shadow maps and the shadow catcher's factors into factor_tex (over shadow_rect); false
  // when there is nothing to shadow.
  bool draw_shadow_factors();
  glm::vec4 shadow_rect{0.0f};  // the catcher's rectangle of z = 0: (x0, y0, x1, y1)
  // The factors read back and multiplied into a copy of the frame: when some are below 1,
  // `shadowed` is the frame with them applied and the result is true (composite()).
  bool apply_shadow_on_cpu(const ImageU8View& frame);
  // The factors multiplied into the output's camera frame by blending (composite_in_place()).
  void apply_shadow_on_gpu(bool rgb);
  Program shadow_apply, shadow_apply_rgb;  // shadow_apply.frag, made when first used
  ImageU8 shadowed;
  std::vector<float> across;   // the factor rows upsampled horizontally
  std::vector<int> taps;       // per column of the box: the left factor texel ...
  std::vector<float> weights;  // ... and the right one's weight

  FrameTimings timings;
  Clock::time_point frame_start = Clock::now();
  std::vector<std::uint8_t> rgba;  // readback buffer
  bool composited = false;

  GLuint texture_for(const std::shared_ptr<const TextureImage>& img) {
    auto it = textures.find(img.get());
    if (it != textures.end() && !it->second.owner.expired() && it->second.owner.lock() == img)
      return it->second.tex.id;
    // Drop entries whose images are gone (their addresses may be reused).
    std::erase_if(textures, [](const auto& kv) { return kv.second.owner.expired(); });
    auto& e = textures[img.get()];
    e.owner = img;
    e.tex = upload_material_texture(*img);
    return e.tex.id;
  }

  const IblProgram& ibl_program(Projection projection, unsigned features) {
    const unsigned key = unsigned(projection) | features << 2;
    auto it = ibl.find(key);
    if (it != ibl.end()) return it->second;
    std::vector<std::pair<std::string, std::string>> defines = {
        {"ENV_PROJECTION", std::to_string(int(projection))}};
    const std::pair<Feature, const char*> names[] = {{kDiffuse, "USE_DIFFUSE"},
                                                     {kAlbedoMap, "USE_ALBEDO"},
                                                     {kNormalMap, "USE_NORMAL_MAP"},
                                                     {kLightMap, "USE_LIGHT_MAP"},
                                                     {kSpecular, "USE_SPECULAR"},
                                                     {kMix, "MIX_REFLECTIONS"},
                                                     {kHemisphere, "HEMISPHERE"},
                                                     {kGlass, "GLASS"},
                                                     {kLiveRefraction, "LIVE_REFRACTION"},
                                                     {kTransfer, "USE_TRANSFER"}};
    for (auto [bit, name] : names)
      if (features & bit) defines.emplace_back(name, "1");
    if (features & kLiveRefraction)
      defines.emplace_back("FRAME_RGB", features & kFrameRgb ? "1" : "0");
    IblProgram ip;
    ip.program = Program(shader_dir, "ibl.vert", "ibl.frag", defines);
    const Program& pr = ip.program;
    ip.model = pr.uniform("u_model"), ip.normal_matrix = pr.uniform("u_normal_matrix");
    ip.view_proj = pr.uniform("u_view_proj"), ip.reflection_mix = pr.uniform("u_reflection_mix");
    ip.camera_position = pr.uniform("u_camera_position");
    ip.world_from_scene = pr.uniform("u_world_from_scene");
    ip.kd = pr.uniform("u_kd"), ip.ks = pr.uniform("u_ks");
    ip.normal_strength = pr.uniform("u_normal_strength");
    ip.sky = pr.uniform("u_sky"), ip.ground = pr.uniform("u_ground");
    ip.occlusion = pr.uniform("u_occlusion");
    ip.ior = pr.uniform("u_ior"), ip.transmission = pr.uniform("u_transmission");
    ip.object_from_scene = pr.uniform("u_object_from_scene");
    ip.ellipsoid_centre = pr.uniform("u_ellipsoid_centre");
    ip.ellipsoid_axes = pr.uniform("u_ellipsoid_axes");
    ip.inv_exposure_gain = pr.uniform("u_inv_exposure_gain");
    ip.light_sh = pr.uniform("u_light_sh");
    glUseProgram(pr.id());
    glUniform1i(pr.uniform("u_irradiance"), kIrr);
    glUniform1i(pr.uniform("u_reflection0"), kRefl0);
    glUniform1i(pr.uniform("u_reflection1"), kRefl1);
    glUniform1i(pr.uniform("u_albedo"), kAlbedo);
    glUniform1i(pr.uniform("u_normal_map"), kNormal);
    glUniform1i(pr.uniform("u_light_map"), kLight);
    glUniform1i(pr.uniform("u_frame"), kFrame);
    glUniform1i(pr.uniform("u_response_inverse"), kResponseInverse);
    return ibl.emplace(key, std::move(ip)).first->second;
  }

  const EnvSet& lighting() const {
    if (!maps.empty()) return maps;
    if (!sh_maps.empty()) return sh_maps;
    return black;
  }
};

// composite.frag for a ToneMode and a ColourCorrection, for an output holding B, G, R (OpenCV)
// or R, G, B (browser).
const Program& Renderer::Impl::composite_program(int mode, ColourCorrection colour, bool rgb) {
  const unsigned key = unsigned(mode) | unsigned(colour) << 2 | (rgb ? 16u : 0u);
  if (auto it = composites.find(key); it != composites.end()) return it->second;
  Program c(shader_dir, "fullscreen.vert", "composite.frag",
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
  return composites.emplace(key, std::move(c)).first->second;
}

Renderer::Renderer(int width, int height, const std::filesystem::path& shader_dir)
    : p_(std::make_unique<Impl>()) {
  if (width < 1 || height < 1) throw std::invalid_argument("Renderer: size must be positive");
  if (!glGetString(GL_VERSION)) throw GlError("Renderer: no current OpenGL ES context");
  GLint major = 0;
  glGetIntegerv(GL_MAJOR_VERSION, &major);
  if (major < 3)
    throw GlError("Renderer: needs OpenGL ES 3, the context is " +
                  std::string(reinterpret_cast<const char*>(glGetString(GL_VERSION))));
  bool float_targets = false;
  GLint n_ext = 0;
  glGetIntegerv(GL_NUM_EXTENSIONS, &n_ext);
  for (GLint i = 0; i < n_ext; ++i)
    if (std::string_view(reinterpret_cast<const char*>(glGetStringi(GL_EXTENSIONS, GLuint(i)))) ==
        "GL_EXT_color_buffer_float")
      float_targets = true;
  if (!float_targets)
    throw GlError(
        "Renderer: OpenGL ES extension GL_EXT_color_buffer_float is missing (needed for the "
        "RGBA16F HDR target)");
  Impl& p = *p_;
  p.w = width, p.h = height;
  p.shader_dir = shader_dir;

  // The common variant (diffuse + mixed specular, lat-long) compiled now: shader errors show
  // up at construction.
  p.ibl_program(Projection::LatLong, kDiffuse | kSpecular | kMix);
  const std::string block = std::to_string(kReduceBlock);
  p.reduce_first = Program(shader_dir, "fullscreen.vert", "loglum_reduce.frag",
                           {{"BLOCK", block}, {"FIRST_PASS", "1"}});
  p.reduce = Program(shader_dir, "fullscreen.vert", "loglum_reduce.frag", {{"BLOCK", block}});
  for (int mode = 0; mode < 3; ++mode) p.composite_program(mode, ColourCorrection::None, false);
  p.present = Program(shader_dir, "fullscreen.vert", "present.frag", {{"FRAME_RGB", "0"}});
  glGenVertexArrays(1, &p.empty_vao);

  // HDR target: RGBA16F radiance + R8 mask + depth. Only the mask and depth are cleared each
  // frame (llvmpipe clears float targets slowly); radiance is read only where the mask is set.
  auto make_target = [&](gl::Texture& tex, GLenum internal, GLenum format, GLenum type, int tw,
                         int th) {
    tex.create();
    glBindTexture(GL_TEXTURE_2D, tex.id);
    glTexImage2D(GL_TEXTURE_2D, 0, GLint(internal), tw, th, 0, format, type, nullptr);
    gl::set_sampling(GL_TEXTURE_2D, GL_NEAREST, GL_CLAMP_TO_EDGE, GL_CLAMP_TO_EDGE);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAX_LEVEL, 0);
  };
  make_target(p.hdr_tex, GL_RGBA16F, GL_RGBA, GL_HALF_FLOAT, width, height);
  make_target(p.mask_tex, GL_R8, GL_RED, GL_UNSIGNED_BYTE, width, height);
  p.depth.create();
  glBindRenderbuffer(GL_RENDERBUFFER, p.depth.id);
  glRenderbufferStorage(GL_RENDERBUFFER, GL_DEPTH_COMPONENT24, width, height);
  p.hdr_fbo.create();
  glBindFramebuffer(GL_FRAMEBUFFER, p.hdr_fbo.id);
  glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, p.hdr_tex.id, 0);
  glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT1, GL_TEXTURE_2D, p.mask_tex.id, 0);
  glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, p.depth.id);
  const GLenum both[2] = {GL_COLOR_ATTACHMENT0, GL_COLOR_ATTACHMENT1};
  glDrawBuffers(2, both);
  gl::check_framebuffer("HDR target (RGBA16F + R8 mask + depth)");

  // The output: the camera frame's BGR bytes are uploaded straight into it (RGB8 holding B, G,
  // R), and the composite pass overwrites only the virtual pixels: it shares the HDR depth
  // buffer and draws at the far plane with GL_GREATER, so only pixels with geometry pass.
  make_target(p.out_tex, GL_RGB8, GL_RGB, GL_UNSIGNED_BYTE, width, height);
  p.out_fbo.create();
  glBindFramebuffer(GL_FRAMEBUFFER, p.out_fbo.id);
  glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, p.out_tex.id, 0);
  glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, p.depth.id);
  gl::check_framebuffer("composite target (RGB8 + the HDR depth)");

  for (int lw = width, lh = height; lw > 1 || lh > 1;) {
    lw = (lw + kReduceBlock - 1) / kReduceBlock, lh = (lh + kReduceBlock - 1) / kReduceBlock;
    Impl::Level& l = p.levels.emplace_back();
    l.w = lw, l.h = lh;
    make_target(l.tex, GL_RG32F, GL_RG, GL_FLOAT, lw, lh);
    l.fbo.create();
    glBindFramebuffer(GL_FRAMEBUFFER, l.fbo.id);
    glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, l.tex.id, 0);
    gl::check_framebuffer("log-luminance reduction level (RG32F)");
  }
  if (p.levels.empty()) {  // a 1x1 renderer still needs the 1x1 sum
    Impl::Level& l = p.levels.emplace_back();
    l.w = l.h = 1;
    make_target(l.tex, GL_RG32F, GL_RG, GL_FLOAT, 1, 1);
    l.fbo.create();
    glBindFramebuffer(GL_FRAMEBUFFER, l.fbo.id);
    glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, l.tex.id, 0);
    gl::check_framebuffer("log-luminance reduction level (RG32F)");
  }

  const std::uint8_t white[4] = {255, 255, 255, 255}, flat[4] = {128, 128, 255, 255};
  for (auto [tex, px] : {std::pair{&p.white_tex, white}, std::pair{&p.flat_normal_tex, flat}}) {
    tex->create();
    glBindTexture(GL_TEXTURE_2D, tex->id);
    glTexImage2D(GL_TEXTURE_2D, 0, GL_RGBA8, 1, 1, 0, GL_RGBA, GL_UNSIGNED_BYTE, px);
    gl::set_sampling(GL_TEXTURE_2D, GL_NEAREST, GL_REPEAT, GL_REPEAT);
  }
  EnvMap zero(EnvLayout::for_size(Projection::LatLong, 1));
  p.black.upload({1.0}, {zero});
  upload_response_lut(CameraResponse::srgb(), p.response_lut);
  upload_response_inverse(CameraResponse::srgb(), p.response_inverse);
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
  gl::check("creating the renderer");
}

Renderer::~Renderer() {
  if (p_ && p_->empty_vao) glDeleteVertexArrays(1, &p_->empty_vao);
}

int Renderer::width() const { return p_->w; }
int Renderer::height() const { return p_->h; }

void Renderer::set_sh(const ShCoeffs& sh) {
  if (sh.order < 1 || sh.c.size() != std::size_t(sh_count(sh.order)))
    throw std::invalid_argument("set_sh: coefficients do not match their order");
  Impl& p = *p_;
  if (sh.order == p.last_sh.order && sh.c == p.last_sh.c) return;
  p.last_sh = sh;
  if (p.maps.empty()) p.set_room_sh(sh);
  p.irradiance_sh = sh_convolve(sh, phong_zonal_all(sh.order, 1.0));
  const EnvLayout layout = EnvLayout::for_size(Projection::LatLong, kShMapSize);
  std::vector<EnvMap> maps;
  for (double s : kShShininess) {
    // Thesis eq. 2.33: band l times Lambda_l rho_l of the normalized Phong lobe (s = 1: the
    // clamped cosine, i.e. irradiance / pi, the irradiance map's value).
    Image img = sh_reconstruct(sh_convolve(sh, phong_zonal_all(sh.order, s)), layout);
    for (float& v : img.storage()) v = std::max(v, 0.0f);  // truncation ringing
    maps.emplace_back(layout, std::move(img));
  }
  p.sh_maps.upload(kShShininess, maps);
  p.sh_priors.reset();
}

void Renderer::set_maps(const std::vector<double>& shininess, const std::vector<EnvMap>& maps) {
  if (maps.empty() || maps.size() != shininess.size())
    throw std::invalid_argument("set_maps: need one map per shininess, at least one");
  for (std::size_t i = 0; i < maps.size(); ++i) {
    if (maps[i].layout.projection() != maps[0].layout.projection())
      throw std::invalid_argument("set_maps: all maps must have one projection");
    if (!(shininess[i] > 0.0)) throw std::invalid_argument("set_maps: shininess must be positive");
  }
  p_->maps.upload(shininess, maps);
  const std::size_t smallest =
      std::size_t(std::min_element(shininess.begin(), shininess.end()) - shininess.begin());
  // For the shadow's f (ShadowSettings) and the hemisphere priors.
  p_->irradiance_map_sh = sh_project(maps[smallest], 2);
  // The sharpest map is nearest the room's radiance: the colour priors' (made when needed).
  const std::size_t sharpest =
      std::size_t(std::max_element(shininess.begin(), shininess.end()) - shininess.begin());
  p_->sharpest_map = maps[sharpest];
  p_->set_room_sh(sh_project(maps[sharpest], 3));
  p_->map_priors.reset(), p_->light_tree.reset();
}

void Renderer::clear_maps() {
  p_->maps = EnvSet();
  p_->irradiance_map_sh.reset();
  p_->sharpest_map.reset(), p_->map_priors.reset(), p_->light_tree.reset();
  if (p_->last_sh.order > 0)
    p_->set_room_sh(p_->last_sh);
  else
    p_->room_sh = ShCoeffs();
}

void Renderer::set_shadow(const ShadowSettings& settings) {
  if (settings.map_size < 16 || settings.map_size > 4096)
    throw std::invalid_argument("set_shadow: map_size must be in [16, 4096]");
  p_->shadow = settings;
}

const ShadowSettings& Renderer::shadow() const { return p_->shadow; }

float Renderer::shadow_fraction() const { return p_->shadow_fraction(); }

LightingSource Renderer::lighting_source() const {
  if (!p_->maps.empty()) return LightingSource::Maps;
  if (!p_->sh_maps.empty()) return LightingSource::Sh;
  return LightingSource::None;
}

void Renderer::set_reflection_lookup(ReflectionLookup lookup) { p_->lookup = lookup; }

void Renderer::set_shading(Shading shading) { p_->shading = shading; }

Shading Renderer::shading() const { return p_->shading; }

void Renderer::set_refraction(Refraction refraction) { p_->refraction = refraction; }

Refraction Renderer::refraction() const { return p_->refraction; }

HemispherePriors Renderer::hemisphere_priors() const { return p_->hemisphere_priors(); }

EnvironmentPriors Renderer::environment_priors() const { return p_->environment_priors(); }

void Renderer::set_environment_priors(std::optional<EnvironmentPriors> priors) {
  p_->priors_override = priors;
}

void Renderer::set_camera(const CameraIntrinsics& k, const glm::dmat4& camera_from_scene,
                          float near_plane, float far_plane) {
  const glm::mat4 proj = projection_from_intrinsics(k, p_->w, p_->h, near_plane, far_plane);
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
  p.casters.clear();
  p.live_glass.clear();
  glBindFramebuffer(GL_FRAMEBUFFER, p.hdr_fbo.id);
  glViewport(0, 0, p.w, p.h);
  const float zero[4] = {0, 0, 0, 0};
  glClearBufferfv(GL_COLOR, 1, zero);  // the mask; radiance stays (read only where masked)
  glClearBufferfi(GL_DEPTH_STENCIL, 0, 1.0f, 0);
}

void Renderer::Impl::issue(const GpuMesh& mesh, const Material& m, const glm::mat4& model,
                           const DrawState& st, unsigned live, float inv_exposure_gain) {
  Impl& p = *this;
  const EnvSet& env = p.lighting();
  const auto [a, b, t] = env.pick(m.shininess, p.lookup);
  const bool use_normal = m.normal_map && mesh.has_tangents();
  const bool use_albedo = m.albedo && mesh.has_uvs(), use_light = m.light_map && mesh.has_uvs();
  const bool glass = m.transmissive();
  const bool diffuse = m.kd != glm::vec3(0.0f), specular = m.ks != glm::vec3(0.0f) && !glass;
  const bool hemisphere = p.shading != Shading::ImageBased;
  const bool transfer = diffuse && !hemisphere && mesh.has_transfer() && p.room_sh.order > 0;
  const unsigned features =
      (diffuse ? kDiffuse : 0u) | (diffuse && use_albedo ? kAlbedoMap : 0u) |
      (use_normal ? kNormalMap : 0u) | (diffuse && use_light ? kLightMap : 0u) |
      (specular ? kSpecular : 0u) | ((specular || glass) && a != b && !hemisphere ? kMix : 0u) |
      (hemisphere ? kHemisphere : 0u) | (glass ? kGlass | live : 0u) | (transfer ? kTransfer : 0u);
  const IblProgram& u = p.ibl_program(hemisphere ? Projection::LatLong : env.projection, features);
  glBindFramebuffer(GL_FRAMEBUFFER, p.hdr_fbo.id);
  glViewport(0, 0, p.w, p.h);
  glEnable(GL_DEPTH_TEST);
  glDepthFunc(GL_LESS);
  glDisable(GL_BLEND);
  if (m.double_sided && !glass) {  // glass is drawn from the front (its far side is modelled)
    glDisable(GL_CULL_FACE);
  } else {
    // Counter-clockwise front faces (glTF) appear clockwise on the targets, which are stored
    // top row first (the projection flips y).
    glEnable(GL_CULL_FACE);
    glCullFace(GL_BACK);
    glFrontFace(GL_CW);
  }
  glUseProgram(u.program.id());
  glUniformMatrix4fv(u.model, 1, GL_FALSE, glm::value_ptr(model));
  const glm::mat3 normal_matrix = glm::inverseTranspose(glm::mat3(model));
  glUniformMatrix3fv(u.normal_matrix, 1, GL_FALSE, glm::value_ptr(normal_matrix));
  glUniformMatrix4fv(u.view_proj, 1, GL_FALSE, glm::value_ptr(st.view_proj));
  glUniform3fv(u.camera_position, 1, glm::value_ptr(st.camera_position));
  glUniformMatrix3fv(u.world_from_scene, 1, GL_FALSE, glm::value_ptr(st.world_from_scene));
  glUniform3fv(u.kd, 1, glm::value_ptr(m.kd));
  glUniform3fv(u.ks, 1, glm::value_ptr(m.ks));
  if (glass) {
    glUniform1f(u.ior, m.ior);
    glUniform3fv(u.transmission, 1, glm::value_ptr(m.transmission));
    const glm::mat4 object_from_scene = glm::inverse(model);
    glUniformMatrix4fv(u.object_from_scene, 1, GL_FALSE, glm::value_ptr(object_from_scene));
    const Bounds& bounds = mesh.bounds();
    const glm::vec3 centre = 0.5f * (bounds.min + bounds.max);
    const glm::vec3 axes = glm::max(0.5f * (bounds.max - bounds.min), glm::vec3(1e-6f));
    glUniform3fv(u.ellipsoid_centre, 1, glm::value_ptr(centre));
    glUniform3fv(u.ellipsoid_axes, 1, glm::value_ptr(axes));
    if (live) {
      glUniform1f(u.inv_exposure_gain, inv_exposure_gain);
      glActiveTexture(GL_TEXTURE0 + kFrame);
      glBindTexture(GL_TEXTURE_2D, p.frame_copy.id);
      glActiveTexture(GL_TEXTURE0 + kResponseInverse);
      glBindTexture(GL_TEXTURE_2D, p.response_inverse.id);
    }
  }
  if (transfer) {
    // The room's SH in the object's frame: L_obj(w) = L_world(world_from_object w).
    const ShCoeffs l =
        sh_rotate(p.room_sh, glm::dmat3(world_from_object(st.world_from_scene, model)));
    std::array<glm::vec3, kTransferCoefficients> v;
    for (std::size_t k = 0; k < v.size(); ++k) v[k] = glm::vec3(l.c[k]);
    glUniform3fv(u.light_sh, GLsizei(v.size()), glm::value_ptr(v[0]));
  }
  if (hemisphere) {
    const HemispherePriors h = p.hemisphere_priors();
    glUniform3fv(u.sky, 1, glm::value_ptr(h.upper));
    glUniform3fv(u.ground, 1, glm::value_ptr(h.lower));
    // The occlusion factor's range, down to up: (shadow / light, 1), or none.
    const bool occlude = p.shading == Shading::HemisphereOcclusion && h.light > 0.0f;
    glUniform2f(u.occlusion, occlude ? h.shadow / h.light : 1.0f, 1.0f);
  }

  // Environment maps: irradiance = the smallest shininess; reflection = around m.shininess.
  const GLenum target = env_target(env.projection);
  glUniform1f(u.reflection_mix, t);
  for (auto [unit, index] :
       {std::pair{kIrr, std::size_t(0)}, std::pair{kRefl0, a}, std::pair{kRefl1, b}}) {
    glActiveTexture(GL_TEXTURE0 + GLenum(unit));
    glBindTexture(target, env.tex[index].id);
  }
  glUniform1f(u.normal_strength, m.normal_strength);
  glActiveTexture(GL_TEXTURE0 + kAlbedo);
  glBindTexture(GL_TEXTURE_2D, use_albedo ? p.texture_for(m.albedo) : p.white_tex.id);
  glActiveTexture(GL_TEXTURE0 + kNormal);
  glBindTexture(GL_TEXTURE_2D, use_normal ? p.texture_for(m.normal_map) : p.flat_normal_tex.id);
  glActiveTexture(GL_TEXTURE0 + kLight);
  glBindTexture(GL_TEXTURE_2D, use_light ? p.texture_for(m.light_map) : p.white_tex.id);

  glBindVertexArray(mesh.vao());
  if (!mesh.has_uvs()) glVertexAttrib2f(2, 0.0f, 0.0f);
  if (!mesh.has_tangents()) glVertexAttrib4f(3, 1.0f, 0.0f, 0.0f, 1.0f);
  if (!mesh.has_occlusion()) glVertexAttrib4f(4, 0.0f, 0.0f, 0.0f, 1.0f);  // nothing baked
  glDrawElements(GL_TRIANGLES, GLsizei(mesh.index_count()), GL_UNSIGNED_INT, nullptr);
  glBindVertexArray(0);
  gl::check("draw");
}

void Renderer::draw(const GpuMesh& mesh, const Material& m, const glm::mat4& model) {
  Impl& p = *p_;
  if (m.transmissive() && p.refraction == Refraction::LiveFrame)
    p.live_glass.push_back({&mesh, m, model, p.draw_state()});
  else
    p.issue(mesh, m, model, p.draw_state(), 0, 1.0f);
  if (p.shadow.enabled) {
    Caster c{mesh.vao(), GLsizei(mesh.index_count()), model, glm::vec3(1e30f), glm::vec3(-1e30f)};
    const Bounds& b = mesh.bounds();
    for (int i = 0; i < 8; ++i) {
      const glm::vec3 corner(i & 1 ? b.max.x : b.min.x, i & 2 ? b.max.y : b.min.y,
                             i & 4 ? b.max.z : b.min.z);
      const glm::vec3 q = glm::vec3(model * glm::vec4(corner, 1.0f));
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
      c.world_from_object = world_from_object(p.world_from_scene, model);
    }
    p.casters.push_back(c);
  }
}

void Renderer::composite(const ImageU8View& frame, const ToneMapping& tone, ImageU8& out) {
  out.resize(p_->w, p_->h, 3);
  composite(frame, tone, std::span(out.data(), std::size_t(p_->w) * p_->h * 3));
}

void Renderer::composite(const ImageU8View& frame, const ToneMapping& tone,
                         std::span<std::uint8_t> out) {
  Impl& p = *p_;
  if (!frame.data || frame.channels != 3 || frame.width != p.w || frame.height != p.h ||
      frame.stride < std::ptrdiff_t(p.w) * 3)
    throw std::invalid_argument("composite: the camera frame must be 8-bit BGR of " +
                                std::to_string(p.w) + "x" + std::to_string(p.h));
  if (out.size() != std::size_t(p.w) * p.h * 3)
    throw std::invalid_argument("composite: the output must hold " + std::to_string(p.w) + "x" +
                                std::to_string(p.h) + "x3 bytes");
  const auto t0 = p.begin_composite(tone, /*wait=*/true);

  // Shadows on the floor: the factors at low resolution on the GPU, multiplied into a copy of
  // the frame where they are below 1 (before the upload; the objects' pixels get darkened too,
  // but the composite pass overwrites every one of them).
  p.timings.shadow_ms = 0, p.timings.shadow_lights = 0;
  ImageU8View camera = frame;
  if (p.shadow.enabled && !p.casters.empty()) {
    const auto ts = Clock::now();
    if (p.draw_shadow_factors() && p.apply_shadow_on_cpu(frame)) camera = p.shadowed.view();
    p.timings.shadow_ms = ms_since(ts);
    glBindVertexArray(p.empty_vao);
  }

  // The camera frame, in place, straight into the output (BGR bytes in an RGB8 texture).
  glActiveTexture(GL_TEXTURE1);
  glBindTexture(GL_TEXTURE_2D, p.out_tex.id);
  glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
  if (camera.stride % 3 == 0) {  // rows a whole number of pixels apart: one upload
    glPixelStorei(GL_UNPACK_ROW_LENGTH, GLint(camera.stride / 3));
    glTexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, p.w, p.h, GL_RGB, GL_UNSIGNED_BYTE, camera.data);
  } else {
    glPixelStorei(GL_UNPACK_ROW_LENGTH, 0);
    for (int y = 0; y < p.h; ++y)
      glTexSubImage2D(GL_TEXTURE_2D, 0, 0, y, p.w, 1, GL_RGB, GL_UNSIGNED_BYTE, camera.row(y));
  }
  glPixelStorei(GL_UNPACK_ROW_LENGTH, 0);
  glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
  glBindTexture(GL_TEXTURE_2D, 0);

  p.draw_live_glass(tone, false);
  p.tone_map_and_composite(tone, false);
  p.timings.tonemap_ms = ms_since(t0);

  p.composited = true;
  // The texture holds B, G, R: dropping alpha gives OpenCV's BGR. (Reading GL_RGB directly,
  // where the implementation offers it, was slower on Mesa: it converts per pixel.)
  const auto t1 = Clock::now();
  p.rgba.resize(std::size_t(p.w) * p.h * 4);
  glPixelStorei(GL_PACK_ALIGNMENT, 4);
  glReadPixels(0, 0, p.w, p.h, GL_RGBA, GL_UNSIGNED_BYTE, p.rgba.data());
  gl::check("reading the composited frame");
  // One 4-byte store per pixel, each overwriting the previous one's spare byte; the last pixel
  // copies its 3 bytes alone.
  const std::size_t pixels = std::size_t(p.w) * p.h;
  for (std::size_t i = 0; i + 1 < pixels; ++i) std::memcpy(&out[3 * i], &p.rgba[4 * i], 4);
  std::memcpy(&out[3 * (pixels - 1)], &p.rgba[4 * (pixels - 1)], 3);
  p.timings.readback_ms = ms_since(t1);
}

unsigned Renderer::camera_texture() const { return p_->out_tex.id; }

void Renderer::composite_in_place(const ToneMapping& tone) {
  Impl& p = *p_;
  // No glFinish: in a browser it is a round trip to the GPU process that stalls the page (the
  // timings are then the time to issue the frame, not to draw it).
  const auto t0 = p.begin_composite(tone, /*wait=*/false);
  p.timings.shadow_ms = 0, p.timings.shadow_lights = 0;
  if (p.shadow.enabled && !p.casters.empty()) {
    const auto ts = Clock::now();
    if (p.draw_shadow_factors()) p.apply_shadow_on_gpu(true);
    p.timings.shadow_ms = ms_since(ts);
    glBindVertexArray(p.empty_vao);
  }
  p.draw_live_glass(tone, true);
  p.tone_map_and_composite(tone, true);
  p.timings.tonemap_ms = ms_since(t0);
  p.timings.readback_ms = 0;
  p.composited = true;
}

// Checks the tone mapping, ends the render timing (after the GPU finished, with `wait`) and sets
// the state the fullscreen passes need; the start of the compositing's timing.
Clock::time_point Renderer::Impl::begin_composite(const ToneMapping& tone, bool wait) {
  if (!(tone.exposure > 0) || !(tone.gain > 0) || !(tone.key > 0) || !(tone.white > 0))
    throw std::invalid_argument("composite: exposure, gain, key and white must be positive");
  if (wait) glFinish();
  timings.render_ms = ms_since(frame_start);
  const auto t0 = Clock::now();
  glDisable(GL_DEPTH_TEST);
  glDisable(GL_BLEND);
  glDisable(GL_CULL_FACE);
  glBindVertexArray(empty_vao);
  return t0;
}

void Renderer::Impl::draw_live_glass(const ToneMapping& tone, bool rgb) {
  timings.refraction_ms = 0;
  if (live_glass.empty()) return;
  const auto t0 = Clock::now();
  if (!frame_copy.id) {
    frame_copy.create();
    glBindTexture(GL_TEXTURE_2D, frame_copy.id);
    glTexImage2D(GL_TEXTURE_2D, 0, GL_RGB8, w, h, 0, GL_RGB, GL_UNSIGNED_BYTE, nullptr);
    gl::set_sampling(GL_TEXTURE_2D, GL_LINEAR, GL_CLAMP_TO_EDGE, GL_CLAMP_TO_EDGE);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAX_LEVEL, 0);
  }
  // The output holds the frame now (uploaded, or the page's); the glass samples a copy of it.
  glBindFramebuffer(GL_FRAMEBUFFER, out_fbo.id);
  glActiveTexture(GL_TEXTURE0 + kFrame);
  glBindTexture(GL_TEXTURE_2D, frame_copy.id);
  glCopyTexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, 0, 0, w, h);
  const float inv_exposure_gain = float(1.0 / (tone.exposure * tone.gain));
  for (const DeferredDraw& d : live_glass)
    issue(*d.mesh, d.material, d.model, d.state, kLiveRefraction | (rgb ? kFrameRgb : 0u),
          inv_exposure_gain);
  live_glass.clear();
  // Back to the fullscreen passes' state (begin_composite()).
  glDisable(GL_DEPTH_TEST);
  glDisable(GL_CULL_FACE);
  glBindVertexArray(empty_vao);
  if (!rgb) glFinish();  // composite() waits for the GPU anyway: time this part on its own
  gl::check("live refraction");
  timings.refraction_ms = ms_since(t0);
}

void Renderer::Impl::measure_colour(const ToneMapping& tone) {
  if (colour_levels.empty()) {
    const std::string block = std::to_string(kReduceBlock);
    colour_first =
        Program(shader_dir, "fullscreen.vert", "colour_stats_reduce.frag",
                {{"BLOCK", block}, {"FIRST_PASS", "1"}, {"STEP", std::to_string(kColourStep)}});
    colour_reduce =
        Program(shader_dir, "fullscreen.vert", "colour_stats_reduce.frag", {{"BLOCK", block}});
    for (int lw = w, lh = h; lw > 1 || lh > 1 || colour_levels.empty();) {
      const int span = kReduceBlock * (colour_levels.empty() ? kColourStep : 1);
      lw = (lw + span - 1) / span, lh = (lh + span - 1) / span;
      ColourLevel& l = colour_levels.emplace_back();
      l.w = lw, l.h = lh;
      l.fbo.create();
      glBindFramebuffer(GL_FRAMEBUFFER, l.fbo.id);
      for (auto [tex, attachment] :
           {std::pair{&l.sum, GL_COLOR_ATTACHMENT0}, std::pair{&l.sum2, GL_COLOR_ATTACHMENT1}}) {
        tex->create();
        glBindTexture(GL_TEXTURE_2D, tex->id);
        glTexImage2D(GL_TEXTURE_2D, 0, GL_RGBA32F, lw, lh, 0, GL_RGBA, GL_FLOAT, nullptr);
        gl::set_sampling(GL_TEXTURE_2D, GL_NEAREST, GL_CLAMP_TO_EDGE, GL_CLAMP_TO_EDGE);
        glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAX_LEVEL, 0);
        glFramebufferTexture2D(GL_FRAMEBUFFER, attachment, GL_TEXTURE_2D, tex->id, 0);
      }
      const GLenum both[2] = {GL_COLOR_ATTACHMENT0, GL_COLOR_ATTACHMENT1};
      glDrawBuffers(2, both);
      gl::check_framebuffer("colour statistics level (2 x RGBA32F)");
    }
  }
  GLuint input = hdr_tex.id, input2 = mask_tex.id;
  int in_w = w, in_h = h;
  for (std::size_t i = 0; i < colour_levels.size(); ++i) {
    const Program& prog = i == 0 ? colour_first : colour_reduce;
    glUseProgram(prog.id());
    glUniform1i(prog.uniform("u_input"), 0);
    glUniform1i(prog.uniform("u_input2"), 1);
    glUniform2i(prog.uniform("u_input_size"), in_w, in_h);
    if (i == 0) {
      glUniform1f(prog.uniform("u_exposure_gain"), float(tone.exposure * tone.gain));
      const glm::mat3 lab = lab_from_rgb();
      glUniformMatrix3fv(prog.uniform("u_lab_from_rgb"), 1, GL_FALSE, glm::value_ptr(lab));
    }
    glActiveTexture(GL_TEXTURE0);
    glBindTexture(GL_TEXTURE_2D, input);
    glActiveTexture(GL_TEXTURE1);
    glBindTexture(GL_TEXTURE_2D, input2);
    glBindFramebuffer(GL_FRAMEBUFFER, colour_levels[i].fbo.id);
    glViewport(0, 0, colour_levels[i].w, colour_levels[i].h);
    glDrawArrays(GL_TRIANGLES, 0, 3);
    input = colour_levels[i].sum.id, input2 = colour_levels[i].sum2.id;
    in_w = colour_levels[i].w, in_h = colour_levels[i].h;
  }
}

// The tone-mapping pass: Reinhard's log-average (when asked) and the composite of the objects'
// pixels into the output, whose other pixels already hold the camera frame.
void Renderer::Impl::tone_map_and_composite(const ToneMapping& tone, bool rgb) {
  Impl& p = *this;
  frame_rgb = rgb;
  if (tone.mode == ToneMode::Reinhard) {
    // Log-average luminance of the masked pixels: block sums down to one texel.
    GLuint input = p.hdr_tex.id;
    int in_w = p.w, in_h = p.h;
    for (std::size_t i = 0; i < p.levels.size(); ++i) {
      const Program& prog = i == 0 ? p.reduce_first : p.reduce;
      glUseProgram(prog.id());
      glUniform1i(prog.uniform("u_input"), 0);
      glUniform1i(prog.uniform("u_mask"), 1);
      glUniform2i(prog.uniform("u_input_size"), in_w, in_h);
      glActiveTexture(GL_TEXTURE0);
      glBindTexture(GL_TEXTURE_2D, input);
      glActiveTexture(GL_TEXTURE1);
      glBindTexture(GL_TEXTURE_2D, p.mask_tex.id);
      glBindFramebuffer(GL_FRAMEBUFFER, p.levels[i].fbo.id);
      glViewport(0, 0, p.levels[i].w, p.levels[i].h);
      glDrawArrays(GL_TRIANGLES, 0, 3);
      input = p.levels[i].tex.id, in_w = p.levels[i].w, in_h = p.levels[i].h;
    }
  }

  const int mode = tone.mode == ToneMode::CameraMatched ? 0
                   : tone.mode == ToneMode::Reinhard    ? 1
                                                        : 2;
  if (tone.colour == ColourCorrection::Match) p.measure_colour(tone);
  const Program& comp = p.composite_program(mode, tone.colour, rgb);
  glUseProgram(comp.id());
  if (tone.colour == ColourCorrection::Match) {
    const EnvironmentPriors& room = p.environment_priors();
    const float eg = float(tone.exposure * tone.gain);
    glUniform3fv(comp.uniform("u_source_mean"), 1, glm::value_ptr(room.lab.mean * eg));
    glUniform3fv(comp.uniform("u_source_sd"), 1, glm::value_ptr(room.lab.sd * eg));
    glActiveTexture(GL_TEXTURE4);
    glBindTexture(GL_TEXTURE_2D, p.colour_levels.back().sum.id);
    glActiveTexture(GL_TEXTURE5);
    glBindTexture(GL_TEXTURE_2D, p.colour_levels.back().sum2.id);
  } else if (tone.colour != ColourCorrection::None) {
    const EnvironmentPriors& room = p.environment_priors();
    glUniform3f(comp.uniform("u_grey"), room.grey_low, room.grey_mean, room.grey_high);
  }
  glUniform1f(comp.uniform("u_exposure_gain"), float(tone.exposure * tone.gain));
  glUniform1f(comp.uniform("u_key"), tone.key);
  glUniform1f(comp.uniform("u_white"), tone.white);
  glActiveTexture(GL_TEXTURE0);
  glBindTexture(GL_TEXTURE_2D, p.hdr_tex.id);
  glActiveTexture(GL_TEXTURE2);
  glBindTexture(GL_TEXTURE_2D, p.response_lut.id);
  glActiveTexture(GL_TEXTURE3);
  glBindTexture(GL_TEXTURE_2D, p.levels.back().tex.id);
  glBindFramebuffer(GL_FRAMEBUFFER, p.out_fbo.id);
  glViewport(0, 0, p.w, p.h);
  glEnable(GL_DEPTH_TEST);  // fullscreen.vert draws at the far plane: passes where depth < 1
  glDepthFunc(GL_GREATER);
  glDepthMask(GL_FALSE);
  glDrawArrays(GL_TRIANGLES, 0, 3);
  glDepthMask(GL_TRUE);
  glDepthFunc(GL_LESS);
  glDisable(GL_DEPTH_TEST);
  glBindVertexArray(0);
  if (!rgb) glFinish();  // composite() times the pass; the browser's path does not wait for it
  gl::check("tone mapping and compositing");
}

bool Renderer::Impl::draw_shadow_factors() {
  // The casters' union bounds (scene frame).
  glm::vec3 lo(1e30f), hi(-1e30f);
  for (const Caster& c : casters) lo = glm::min(lo, c.lo), hi = glm::max(hi, c.hi);
  if (hi.z <= 0.0f) return false;  // everything under the floor
  const glm::vec3 cam = camera_position;
  if (cam.z <= 0.0f) return false;  // seen from under the floor
  const float size = std::max({hi.x - lo.x, hi.y - lo.y, hi.z - lo.z, 1e-6f});

  // The hard shadows to blend (scene frame) and their shares of the floor's light.
  const std::vector<ShadowLight> lights = shadow_lights();
  float f_sum = 0.0f;
  for (const ShadowLight& sl : lights) f_sum += sl.fraction;
  timings.shadow_lights = int(lights.size());

  // The receiver rectangle: the objects' footprints widened to where AO fades out, and the
  // shadows' reach along each -l (at most max_shadow_length object sizes).
  glm::vec2 r0(1e30f), r1(-1e30f);
  for (const Caster& c : casters) {
    const glm::vec2 half = 0.5f * glm::vec2(c.hi - c.lo), mid = 0.5f * glm::vec2(c.hi + c.lo);
    const glm::vec2 reach = std::max(shadow.ao_reach, 0.0f) * glm::max(half, glm::vec2(1e-4f));
    r0 = glm::min(r0, mid - reach), r1 = glm::max(r1, mid + reach);
    for (const ShadowLight& sl : lights) {
      const glm::vec3 l = sl.direction;
      for (int i = 0; i < 8; ++i) {
        const glm::vec3 q(i & 1 ? c.hi.x : c.lo.x, i & 2 ? c.hi.y : c.lo.y,
                          i & 4 ? c.hi.z : c.lo.z);
        glm::vec2 d = -glm::vec2(l) * (std::max(q.z, 0.0f) / l.z);
        const float len = glm::length(d), cap = shadow.max_shadow_length * size;
        if (len > cap) d *= cap / len;
        const glm::vec2 hit = glm::vec2(q) + d;
        r0 = glm::min(r0, hit), r1 = glm::max(r1, hit);
      }
    }
  }

  ensure_shadow_resources(int(lights.size()));
  // Per light, an orthographic view fitted to the casters' bounds, a few texels of margin.
  std::vector<glm::mat4> light_view_proj, shadow_from_scene;
  const glm::mat4 to_tex = glm::translate(glm::mat4(1.0f), glm::vec3(0.5f)) *
                           glm::scale(glm::mat4(1.0f), glm::vec3(0.5f));
  for (const ShadowLight& sl : lights) {
    const glm::vec3 l = sl.direction;
    const glm::vec3 centre = 0.5f * (lo + hi);
    const glm::vec3 up_hint = std::abs(l.z) < 0.99f ? glm::vec3(0, 0, 1) : glm::vec3(0, 1, 0);
    const glm::mat4 view = glm::lookAt(centre + l * (2.0f * size), centre, up_hint);
    glm::vec3 a(1e30f), b(-1e30f);
    for (int i = 0; i < 8; ++i) {
      const glm::vec3 q(i & 1 ? hi.x : lo.x, i & 2 ? hi.y : lo.y, i & 4 ? hi.z : lo.z);
      const glm::vec3 v = glm::vec3(view * glm::vec4(q, 1.0f));
      a = glm::min(a, v), b = glm::max(b, v);
    }
    const float margin = (b.x - a.x + b.y - a.y) * (shadow.pcf_step + 2.0f) / float(shadow_size);
    const glm::mat4 proj = glm::ortho(a.x - margin, b.x + margin, a.y - margin, b.y + margin,
                                      -b.z - margin, -a.z + margin);
    light_view_proj.push_back(proj * view);
    shadow_from_scene.push_back(to_tex * light_view_proj.back());
  }

  // The maps are re-rendered only when a light or a caster moved (in the scene frame).
  std::vector<float> key;
  for (const glm::mat4& m : light_view_proj)
    key.insert(key.end(), glm::value_ptr(m), glm::value_ptr(m) + 16);
  for (const Caster& c : casters) {
    key.push_back(float(c.vao)), key.push_back(float(c.count));
    key.insert(key.end(), glm::value_ptr(c.model), glm::value_ptr(c.model) + 16);
  }
  if (!lights.empty() && key != shadow_key) {
    shadow_key = std::move(key);
    glBindFramebuffer(GL_FRAMEBUFFER, shadow_fbo.id);
    glViewport(0, 0, shadow_size, shadow_size);
    glDisable(GL_BLEND);
    glDisable(GL_CULL_FACE);
    glEnable(GL_DEPTH_TEST);
    glDepthFunc(GL_LESS);
    glDepthMask(GL_TRUE);
    glUseProgram(shadow_depth.id());
    const GLint u_light = shadow_depth.uniform("u_light_view_proj");
    const GLint u_model = shadow_depth.uniform("u_model");
    for (std::size_t i = 0; i < lights.size(); ++i) {
      glFramebufferTextureLayer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, shadow_tex.id, 0, GLint(i));
      glClear(GL_DEPTH_BUFFER_BIT);
      glUniformMatrix4fv(u_light, 1, GL_FALSE, glm::value_ptr(light_view_proj[i]));
      for (const Caster& c : casters) {
        glUniformMatrix4fv(u_model, 1, GL_FALSE, glm::value_ptr(c.model));
        glBindVertexArray(c.vao);
        glDrawElements(GL_TRIANGLES, c.count, GL_UNSIGNED_INT, nullptr);
      }
    }
    glBindVertexArray(0);
  }

  // The catcher, in two passes over the rectangle of z = 0: the code factors at low
  // resolution (1 where there is no shadow), then upsampled bilinearly, depth tested against
  // the objects (no depth writes) and multiplied into the output where they are below 1.
  shadow_rect = glm::vec4(r0, r1);
  const Program& pr = shadow_catcher;
  glUseProgram(pr.id());
  glUniform4fv(pr.uniform("u_rect"), 1, glm::value_ptr(shadow_rect));
  glUniformMatrix4fv(pr.uniform("u_view_proj"), 1, GL_FALSE, glm::value_ptr(view_proj));
  glUniform1i(pr.uniform("u_light_count"), int(lights.size()));
  if (!lights.empty()) {
    glUniformMatrix4fv(pr.uniform("u_shadow_from_scene"), GLsizei(lights.size()), GL_FALSE,
                       glm::value_ptr(shadow_from_scene[0]));
    std::array<float, kMaxShadowLights> fractions{};
    for (std::size_t i = 0; i < lights.size(); ++i) fractions[i] = lights[i].fraction;
    glUniform4fv(pr.uniform("u_light_fraction"), kMaxShadowLights / 4, fractions.data());
  }
  // Few lights: each shadow's edge softened by PCF; many: their overlap is the penumbra.
  glUniform1i(pr.uniform("u_pcf_radius"), lights.size() <= 2 ? 1 : 0);
  glUniform1f(pr.uniform("u_pcf_step"), shadow.pcf_step / float(shadow_size));
  glUniform1f(pr.uniform("u_depth_bias"), 2.0f / float(shadow_size));
  glUniform1f(pr.uniform("u_fraction"), f_sum);
  glUniform1f(pr.uniform("u_ao_strength"), std::max(shadow.ao_strength, 0.0f));
  glUniform1f(pr.uniform("u_ao_reach"), std::max(shadow.ao_reach, 1e-3f));
  glUniform1f(pr.uniform("u_min_ratio"), std::clamp(shadow.min_ratio, 0.0f, 1.0f));
  const int count = std::min<int>(kMaxEllipsoids, int(casters.size()));
  std::vector<glm::vec3> centres, inv_axes;
  for (int k = 0; k < count; ++k) {
    centres.push_back(0.5f * (casters[k].lo + casters[k].hi));
    inv_axes.push_back(1.0f / glm::max(0.5f * (casters[k].hi - casters[k].lo), glm::vec3(1e-5f)));
  }
  glUniform1i(pr.uniform("u_count"), count);
  if (count > 0) {
    glUniform3fv(pr.uniform("u_centre"), count, glm::value_ptr(centres[0]));
    glUniform3fv(pr.uniform("u_inv_axes"), count, glm::value_ptr(inv_axes[0]));
  }
  // The casters' baked floor occlusion, where they have one (tutorial §6.1's receiver plane).
  std::vector<float> has_ground(kMaxEllipsoids, 0.0f);
  std::vector<glm::mat4> ground_from_scene(kMaxEllipsoids, glm::mat4(1.0f));
  for (int k = 0; k < kMaxEllipsoids; ++k) {
    glActiveTexture(GLenum(GL_TEXTURE0 + kGroundUnit + k));
    const bool baked = k < count && casters[std::size_t(k)].ground_tex;
    glBindTexture(GL_TEXTURE_2D, baked ? casters[std::size_t(k)].ground_tex : white_tex.id);
    if (baked) {
      has_ground[std::size_t(k)] = 1.0f;
      ground_from_scene[std::size_t(k)] = casters[std::size_t(k)].ground_from_scene;
    }
  }
  glUniform1fv(pr.uniform("u_has_ground"), kMaxEllipsoids, has_ground.data());
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
  for (int k = 0; k < count && rest.order > 0; ++k) {
    const Caster& c = casters[std::size_t(k)];
    glActiveTexture(GLenum(GL_TEXTURE0 + kGroundTransferUnit + k));
    glBindTexture(GL_TEXTURE_2D_ARRAY, c.ground_transfer_tex);
    if (!c.ground_tex || !c.ground_transfer_tex) continue;
    const glm::dmat3 r(c.world_from_object);
    // What the open lobe of an up-facing floor point (object +Y) gets from a light.
    const auto open = [up = sh_cosine_lobe({0.0, 1.0, 0.0}, 3)](const ShCoeffs& l) {
      glm::dvec3 sum(0.0);
      for (std::size_t j = 0; j < up.size(); ++j) sum += l.c[j] * up[j];
      return sum;
    };
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
  glUniformMatrix4fv(pr.uniform("u_ground_from_scene"), kMaxEllipsoids, GL_FALSE,
                     glm::value_ptr(ground_from_scene[0]));
  glActiveTexture(GL_TEXTURE0);
  glBindTexture(GL_TEXTURE_2D_ARRAY, shadow_tex.id);
  glActiveTexture(GL_TEXTURE2);
  glBindTexture(GL_TEXTURE_2D, response_lut.id);
  glBindFramebuffer(GL_FRAMEBUFFER, factor_fbo.id);
  glViewport(0, 0, factor_w, factor_h);
  glDisable(GL_CULL_FACE);
  glDisable(GL_DEPTH_TEST);
  glDisable(GL_BLEND);
  const float one[4] = {1, 1, 1, 1};
  glClearBufferfv(GL_COLOR, 0, one);
  glBindVertexArray(empty_vao);
  glDrawArrays(GL_TRIANGLE_STRIP, 0, 4);
  glBindVertexArray(0);
  gl::check("shadow catcher");
  return true;
}

void Renderer::Impl::apply_shadow_on_gpu(bool rgb) {
  Program& pr = rgb ? shadow_apply_rgb : shadow_apply;
  if (!pr.id()) {
    pr = rgb ? Program(shader_dir, "shadow_catcher.vert", "shadow_apply.frag", {{"FRAME_RGB", "1"}})
             : Program(shader_dir, "shadow_catcher.vert", "shadow_apply.frag");
    glUseProgram(pr.id());
    glUniform1i(pr.uniform("u_factors"), 0);
  }
  glUseProgram(pr.id());
  glUniform4fv(pr.uniform("u_rect"), 1, glm::value_ptr(shadow_rect));
  glUniformMatrix4fv(pr.uniform("u_view_proj"), 1, GL_FALSE, glm::value_ptr(view_proj));
  glUniform2f(pr.uniform("u_factor_extent"), float(factor_w * kFactorScale),
              float(factor_h * kFactorScale));
  glActiveTexture(GL_TEXTURE0);
  glBindTexture(GL_TEXTURE_2D, factor_tex.id);
  glBindFramebuffer(GL_FRAMEBUFFER, out_fbo.id);
  glViewport(0, 0, w, h);
  glDisable(GL_DEPTH_TEST);
  glDisable(GL_CULL_FACE);
  glEnable(GL_BLEND);
  glBlendFunc(GL_ZERO, GL_SRC_COLOR);  // frame x factor
  glBindVertexArray(empty_vao);
  glDrawArrays(GL_TRIANGLE_STRIP, 0, 4);
  glBindVertexArray(0);
  glDisable(GL_BLEND);
  gl::check("shadow catcher (applied on the GPU)");
}

bool Renderer::Impl::apply_shadow_on_cpu(const ImageU8View& frame) {
  // The factors are read back (small) and applied on the CPU over their bounding box:
  // bilinear upsampling (texel centres as GL samples them) and code * factor / 255, exact
  // where the factor is 255.
  factors.resize(std::size_t(factor_w) * factor_h * 4);
  glPixelStorei(GL_PACK_ALIGNMENT, 4);
  glBindFramebuffer(GL_FRAMEBUFFER, factor_fbo.id);
  glReadPixels(0, 0, factor_w, factor_h, GL_RGBA, GL_UNSIGNED_BYTE, factors.data());
  gl::check("reading the shadow factors");
  int x0 = factor_w, y0 = factor_h, x1 = -1, y1 = -1;
  for (int y = 0; y < factor_h; ++y)
    for (int x = 0; x < factor_w; ++x) {
      const std::uint8_t* f = &factors[(std::size_t(y) * factor_w + x) * 4];
      if ((f[0] & f[1] & f[2]) == 255) continue;
      x0 = std::min(x0, x), x1 = std::max(x1, x), y0 = std::min(y0, y), y1 = std::max(y1, y);
    }
  if (x1 < 0) return false;
  // One texel of ones around the box (bilinear reach), then the box in full-resolution pixels.
  x0 = std::max(0, x0 - 1), y0 = std::max(0, y0 - 1);
  x1 = std::min(factor_w - 1, x1 + 1), y1 = std::min(factor_h - 1, y1 + 1);
  // The frame, with the box's pixels multiplied by the factors upsampled bilinearly (texel
  // centres at (i + 0.5) * scale, clamped at the box's edges: the ring of ones above).
  shadowed.resize(w, h, 3);
  for (int y = 0; y < h; ++y)
    std::copy(frame.row(y), frame.row(y) + std::size_t(w) * 3, shadowed.row(y));
  const int px0 = x0 * kFactorScale, py0 = y0 * kFactorScale;
  const int px1 = std::min(w, (x1 + 1) * kFactorScale), py1 = std::min(h, (y1 + 1) * kFactorScale);
  // Separable: each factor row of the box interpolated across to full resolution once, then
  // every output row between its two factor rows (B, G, R, like the frame).
  const int bw = px1 - px0, rows = y1 - y0 + 1;
  const auto tap = [](int p, int lo, int hi, int& i, float& f) {
    const float s = std::clamp((p + 0.5f) / kFactorScale - 0.5f, float(lo), float(hi));
    i = hi > lo ? std::min(int(s), hi - 1) : lo;
    f = s - float(i);
  };
  across.resize(std::size_t(rows) * bw * 3);
  taps.resize(std::size_t(bw));
  weights.resize(std::size_t(bw));
  for (int x = px0; x < px1; ++x)
    tap(x, x0, x1, taps[std::size_t(x - px0)], weights[std::size_t(x - px0)]);
  for (int j = y0; j <= y1; ++j) {
    const std::uint8_t* src = &factors[std::size_t(j) * factor_w * 4];
    float* out = &across[std::size_t(j - y0) * bw * 3];
    for (int k = 0; k < bw; ++k) {
      const int i = taps[std::size_t(k)], i1 = std::min(i + 1, x1);
      const float fx = weights[std::size_t(k)];
      for (int c = 0; c < 3; ++c)
        out[3 * k + c] = src[4 * i + c] + fx * (float(src[4 * i1 + c]) - float(src[4 * i + c]));
    }
  }
  for (int y = py0; y < py1; ++y) {
    int j;
    float fy;
    tap(y, y0, y1, j, fy);
    const float* a = &across[std::size_t(j - y0) * bw * 3];
    const float* b = &across[std::size_t(std::min(j + 1, y1) - y0) * bw * 3];
    std::uint8_t* row = shadowed.row(y) + std::size_t(px0) * 3;
    for (int k = 0; k < bw * 3; ++k) {
      const float f = a[k] + fy * (b[k] - a[k]);
      // code * factor / 255, rounded (< 255.5 since factor <= 255): exact where the factor is 1;
      // no branch, so it vectorises
      row[k] = std::uint8_t(int(float(row[k]) * f * (1.0f / 255.0f) + 0.5f));
    }
  }
  return true;
}

void Renderer::present() {
  Impl& p = *p_;
  if (!p.composited) return;
  // present.frag flips the rows (the window's row 0 is its bottom) and swaps B and R (unless
  // the output holds the browser's R, G, B frame).
  if (p.frame_rgb && !p.present_rgb.id())
    p.present_rgb = Program(p.shader_dir, "fullscreen.vert", "present.frag", {{"FRAME_RGB", "1"}});
  const Program& present = p.frame_rgb ? p.present_rgb : p.present;
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
  GLint vp[4];
  glGetIntegerv(GL_VIEWPORT, vp);
  glDisable(GL_DEPTH_TEST);
  glDisable(GL_CULL_FACE);
  glUseProgram(present.id());
  glUniform1i(present.uniform("u_image"), 0);
  glActiveTexture(GL_TEXTURE0);
  glBindTexture(GL_TEXTURE_2D, p.out_tex.id);
  glBindVertexArray(p.empty_vao);
  glDrawArrays(GL_TRIANGLES, 0, 3);
  glBindVertexArray(0);
  gl::check("present");
}

const FrameTimings& Renderer::timings() const { return p_->timings; }

HdrReadback Renderer::read_hdr() {
  Impl& p = *p_;
  std::vector<float> px(std::size_t(p.w) * p.h * 4);
  std::vector<std::uint8_t> mask(std::size_t(p.w) * p.h * 4);
  glBindFramebuffer(GL_READ_FRAMEBUFFER, p.hdr_fbo.id);
  glPixelStorei(GL_PACK_ALIGNMENT, 4);
  glReadBuffer(GL_COLOR_ATTACHMENT0);
  glReadPixels(0, 0, p.w, p.h, GL_RGBA, GL_FLOAT, px.data());
  glReadBuffer(GL_COLOR_ATTACHMENT1);
  glReadPixels(0, 0, p.w, p.h, GL_RGBA, GL_UNSIGNED_BYTE, mask.data());
  glReadBuffer(GL_COLOR_ATTACHMENT0);
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
  gl::check("reading the HDR target");
  HdrReadback r{Image(p.w, p.h), std::vector<std::uint8_t>(std::size_t(p.w) * p.h)};
  for (std::size_t i = 0; i < r.mask.size(); ++i) {
    r.mask[i] = mask[4 * i] > 127 ? 1 : 0;
    if (!r.mask[i]) continue;  // stale radiance from earlier frames: report 0
    for (std::size_t c = 0; c < 3; ++c) r.radiance.storage()[3 * i + c] = px[4 * i + c];
  }
  return r;
}

float Renderer::last_log_average() const {
  const Impl& p = *p_;
  float sum[4] = {0, 0, 0, 0};
  glBindFramebuffer(GL_READ_FRAMEBUFFER, p.levels.back().fbo.id);
  glReadPixels(0, 0, 1, 1, GL_RGBA, GL_FLOAT, sum);
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
  return std::exp(sum[0] / std::max(sum[1], 1.0f));
}

}  // namespace arlight::render
