#include "ibl_pass.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <glm/gtc/matrix_inverse.hpp>
#include <glm/gtc/type_ptr.hpp>
#include <string>
#include <utility>
#include <vector>

#include "arlight/common/brdf.hpp"
#include "textures.hpp"

namespace arlight::render {

namespace {

// Texture units.
enum Unit : GLint {
  kIrr = 0, kRefl0, kRefl1, kAlbedo, kNormal, kLight, kFrame, kResponseInverse,
  kMrUnit, kOcclusionUnit, kEmissiveUnit, kDfgUnit, kGgxUnit
};
static_assert(kFrame == IblPass::kFrameUnit);

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
  kMetallicRoughness = 2048,  // glTF metallic-roughness (Material::pbr)
  kGgxChain = 4096,           // ... with the room's GGX chain (else the reflection maps)
  kMrMap = 8192,              // ... its textures
  kOcclusionMap = 16384,
  kEmissiveMap = 32768,
  kAlphaMask = 65536,
  kGgxDiffuse = 131072,       // ... its diffuse light from the chain's roughest level (no map set)
  kAlphaBlend = 262144,       // ... drawn premultiplied by its coverage, blended (glTF BLEND)
  kGgxLights = 524288,        // ... the lights taken out of the chain's room, analytic
};

// The split sum's DFG table the shader looks up: 64 x 64 (bilinear; the table is smooth) at
// 512 samples a texel, ~0.05 s when the first metallic-roughness material is drawn.
constexpr int kDfgSize = 64, kDfgSamples = 512;

// The Phong shininess whose reflection lobe is about as wide as GGX's of perceptual roughness r
// (Blinn-Phong's 2 / alpha^2 - 2 on the half vector is about 4x the exponent on the mirror
// direction): the reflection map a metallic-roughness material samples without a GGX chain.
double equivalent_shininess(double roughness) {
  const double alpha = std::max(roughness * roughness, 1e-3);
  return std::max(1.0, 0.5 / (alpha * alpha) - 0.5);
}

}  // namespace

glm::mat3 world_from_object(const glm::mat3& world_from_scene, const glm::mat4& model) {
  glm::mat3 r = world_from_scene * glm::mat3(model);
  for (int k = 0; k < 3; ++k) r[k] = glm::normalize(r[k]);
  return r;
}

struct IblPass::Variant {
  Program program;
  GLint model = -1, normal_matrix = -1, view_proj = -1, reflection_mix = -1, camera_position = -1,
        world_from_scene = -1, kd = -1, ks = -1, normal_strength = -1, sky = -1, ground = -1,
        occlusion = -1, ior = -1, transmission = -1, object_from_scene = -1, ellipsoid_centre = -1,
        ellipsoid_axes = -1, inv_exposure_gain = -1, light_sh = -1, base_colour = -1,
        metallic_roughness = -1, occlusion_strength = -1, emissive = -1, alpha_cutoff = -1,
        ggx_max_lod = -1, ggx_light_count = -1, ggx_light_direction = -1, ggx_light_power = -1,
        ggx_light_disc = -1;
};

IblPass::IblPass(const std::filesystem::path& shader_dir) : shader_dir_(shader_dir) {
  variant(Projection::LatLong, kDiffuse | kSpecular | kMix);
  white_tex_ = upload_pixel_texture({255, 255, 255, 255});
  flat_normal_tex_ = upload_pixel_texture({128, 128, 255, 255});
}

IblPass::~IblPass() = default;

GLuint IblPass::texture_for(const std::shared_ptr<const TextureImage>& img) {
  auto it = textures_.find(img.get());
  if (it != textures_.end() && !it->second.owner.expired() && it->second.owner.lock() == img)
    return it->second.tex.id;
  // Drop entries whose images are gone (their addresses may be reused).
  std::erase_if(textures_, [](const auto& kv) { return kv.second.owner.expired(); });
  auto& e = textures_[img.get()];
  e.owner = img;
  e.tex = upload_material_texture(*img);
  return e.tex.id;
}

const IblPass::Variant& IblPass::variant(Projection projection, unsigned features) {
  const unsigned key = unsigned(projection) | features << 2;
  auto it = variants_.find(key);
  if (it != variants_.end()) return it->second;
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
                                                   {kTransfer, "USE_TRANSFER"},
                                                   {kMetallicRoughness, "METALLIC_ROUGHNESS"},
                                                   {kGgxChain, "GGX_CHAIN"},
                                                   {kMrMap, "USE_MR_MAP"},
                                                   {kOcclusionMap, "USE_OCCLUSION_MAP"},
                                                   {kEmissiveMap, "USE_EMISSIVE_MAP"},
                                                   {kAlphaMask, "ALPHA_MASK"},
                                                   {kAlphaBlend, "ALPHA_BLEND"},
                                                   {kGgxDiffuse, "GGX_DIFFUSE"},
                                                   {kGgxLights, "GGX_LIGHTS"}};
  for (auto [bit, name] : names)
    if (features & bit) defines.emplace_back(name, "1");
  if (features & kLiveRefraction)
    defines.emplace_back("FRAME_RGB", features & kFrameRgb ? "1" : "0");
  Variant v;
  v.program = Program(shader_dir_, "ibl.vert", "ibl.frag", defines);
  const Program& pr = v.program;
  v.model = pr.uniform("u_model"), v.normal_matrix = pr.uniform("u_normal_matrix");
  v.view_proj = pr.uniform("u_view_proj"), v.reflection_mix = pr.uniform("u_reflection_mix");
  v.camera_position = pr.uniform("u_camera_position");
  v.world_from_scene = pr.uniform("u_world_from_scene");
  v.kd = pr.uniform("u_kd"), v.ks = pr.uniform("u_ks");
  v.normal_strength = pr.uniform("u_normal_strength");
  v.sky = pr.uniform("u_sky"), v.ground = pr.uniform("u_ground");
  v.occlusion = pr.uniform("u_occlusion");
  v.ior = pr.uniform("u_ior"), v.transmission = pr.uniform("u_transmission");
  v.object_from_scene = pr.uniform("u_object_from_scene");
  v.ellipsoid_centre = pr.uniform("u_ellipsoid_centre");
  v.ellipsoid_axes = pr.uniform("u_ellipsoid_axes");
  v.inv_exposure_gain = pr.uniform("u_inv_exposure_gain");
  v.light_sh = pr.uniform("u_light_sh");
  v.base_colour = pr.uniform("u_base_colour");
  v.metallic_roughness = pr.uniform("u_metallic_roughness");
  v.occlusion_strength = pr.uniform("u_occlusion_strength");
  v.emissive = pr.uniform("u_emissive"), v.alpha_cutoff = pr.uniform("u_alpha_cutoff");
  v.ggx_max_lod = pr.uniform("u_ggx_max_lod");
  v.ggx_light_count = pr.uniform("u_ggx_light_count");
  v.ggx_light_direction = pr.uniform("u_ggx_light_direction");
  v.ggx_light_power = pr.uniform("u_ggx_light_power");
  v.ggx_light_disc = pr.uniform("u_ggx_light_disc");
  glUseProgram(pr.id());
  glUniform1i(pr.uniform("u_irradiance"), kIrr);
  glUniform1i(pr.uniform("u_reflection0"), kRefl0);
  glUniform1i(pr.uniform("u_reflection1"), kRefl1);
  glUniform1i(pr.uniform("u_albedo"), kAlbedo);
  glUniform1i(pr.uniform("u_normal_map"), kNormal);
  glUniform1i(pr.uniform("u_light_map"), kLight);
  glUniform1i(pr.uniform("u_frame"), kFrame);
  glUniform1i(pr.uniform("u_response_inverse"), kResponseInverse);
  glUniform1i(pr.uniform("u_mr_map"), kMrUnit);
  glUniform1i(pr.uniform("u_occlusion_map"), kOcclusionUnit);
  glUniform1i(pr.uniform("u_emissive_map"), kEmissiveUnit);
  glUniform1i(pr.uniform("u_dfg"), kDfgUnit);
  glUniform1i(pr.uniform("u_ggx"), kGgxUnit);
  return variants_.emplace(key, std::move(v)).first->second;
}

void IblPass::clear_uncovered(const RenderTargets& targets, const FullscreenPass& fullscreen) {
  if (!clear_uncovered_.id())
    clear_uncovered_ = Program(shader_dir_, "fullscreen.vert", "clear_uncovered.frag", {});
  glBindFramebuffer(GL_FRAMEBUFFER, targets.hdr_fbo.id);
  glViewport(0, 0, targets.w, targets.h);
  glDisable(GL_BLEND);
  glDisable(GL_CULL_FACE);
  glEnable(GL_DEPTH_TEST);
  glDepthFunc(GL_LEQUAL);
  glDepthMask(GL_FALSE);
  glUseProgram(clear_uncovered_.id());
  fullscreen.draw_triangle();
  glDepthMask(GL_TRUE);
  glDepthFunc(GL_LESS);
  gl::check("clearing where nothing was drawn");
}

void IblPass::draw(const GpuMesh& mesh, const Material& m, const glm::mat4& model,
                   const DrawState& st, const SceneLighting& lighting, const RenderTargets& targets,
                   const MeshPart& part, const LiveFrameInputs* live) {
  const EnvSet& env = lighting.maps();
  const MetallicRoughness* pbr = m.pbr ? &*m.pbr : nullptr;
  const bool ggx = pbr && lighting.ggx_levels() > 0 && shading == Shading::ImageBased;
  const auto [a, b, t] =
      env.pick(pbr ? equivalent_shininess(pbr->roughness) : double(m.shininess), lookup);
  const bool use_normal = m.normal_map && mesh.has_tangents();
  const bool use_albedo = m.albedo && mesh.has_uvs(), use_light = m.light_map && mesh.has_uvs();
  const bool glass = m.transmissive();
  const bool diffuse = pbr || m.kd != glm::vec3(0.0f),
             specular = !pbr && m.ks != glm::vec3(0.0f) && !glass;
  const bool hemisphere = shading != Shading::ImageBased;
  const bool transfer =
      diffuse && !hemisphere && mesh.has_transfer() && lighting.room_sh().order > 0;
  const unsigned live_bits = live ? kLiveRefraction | (live->frame_rgb ? kFrameRgb : 0u) : 0u;
  unsigned features = (diffuse ? kDiffuse : 0u) | (diffuse && use_albedo ? kAlbedoMap : 0u) |
                      (use_normal ? kNormalMap : 0u) | (diffuse && use_light ? kLightMap : 0u) |
                      (specular ? kSpecular : 0u) |
                      ((specular || glass || (pbr && !ggx)) && a != b && !hemisphere ? kMix : 0u) |
                      (hemisphere ? kHemisphere : 0u) | (glass ? kGlass | live_bits : 0u) |
                      (transfer ? kTransfer : 0u);
  if (pbr) {
    const bool uvs = mesh.has_uvs();
    // The irradiance map of a map set is finer than the chain's last level (face 16); without
    // one (a client that asked for the chain) the chain's is fresher than the live SH's.
    const bool ggx_diffuse = ggx && lighting.source() != LightingSource::Maps;
    const bool ggx_lights = ggx && !lighting.ggx_lights().empty();
    features |= kMetallicRoughness | (ggx ? kGgxChain : 0u) | (ggx_diffuse ? kGgxDiffuse : 0u) |
                (ggx_lights ? kGgxLights : 0u) |
                (pbr->metallic_roughness && uvs ? kMrMap : 0u) |
                (pbr->occlusion && uvs ? kOcclusionMap : 0u) |
                (pbr->emissive_map && uvs ? kEmissiveMap : 0u) | (pbr->alpha_mask ? kAlphaMask : 0u) |
                (pbr->alpha_blend ? kAlphaBlend : 0u);
    if (dfg_tex_.id == 0) {
      dfg_tex_ = upload_dfg(dfg_table(kDfgSize, kDfgSamples));
    }
  }
  const Variant& u = variant(hemisphere ? Projection::LatLong : env.projection, features);
  glBindFramebuffer(GL_FRAMEBUFFER, targets.hdr_fbo.id);
  glViewport(0, 0, targets.w, targets.h);
  glEnable(GL_DEPTH_TEST);
  glDepthFunc(GL_LESS);
  // BLEND: premultiplied colour over what is there; the coverage (alpha) likewise, so the
  // composite knows how much of the frame still shows. Depth is written: the composite draws
  // where depth was.
  if (pbr && pbr->alpha_blend) {
    glEnable(GL_BLEND);
    glBlendFuncSeparate(GL_ONE, GL_ONE_MINUS_SRC_ALPHA, GL_ONE, GL_ONE_MINUS_SRC_ALPHA);
  } else {
    glDisable(GL_BLEND);
  }
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
  if (pbr) {
    glUniform4fv(u.base_colour, 1, glm::value_ptr(pbr->base_colour));
    glUniform2f(u.metallic_roughness, pbr->metallic, pbr->roughness);
    glUniform1f(u.occlusion_strength, pbr->occlusion_strength);
    glUniform3fv(u.emissive, 1, glm::value_ptr(pbr->emissive));
    glUniform1f(u.alpha_cutoff, pbr->alpha_cutoff);
    glActiveTexture(GL_TEXTURE0 + kDfgUnit);
    glBindTexture(GL_TEXTURE_2D, dfg_tex_.id);
    const bool uvs = mesh.has_uvs();
    for (auto [unit, image] : {std::pair{kMrUnit, &pbr->metallic_roughness},
                               std::pair{kOcclusionUnit, &pbr->occlusion},
                               std::pair{kEmissiveUnit, &pbr->emissive_map}}) {
      glActiveTexture(GL_TEXTURE0 + GLenum(unit));
      glBindTexture(GL_TEXTURE_2D, *image && uvs ? texture_for(*image) : white_tex_.id);
    }
    if (ggx) {
      glUniform1f(u.ggx_max_lod, float(lighting.ggx_levels() - 1));
      glActiveTexture(GL_TEXTURE0 + kGgxUnit);
      glBindTexture(GL_TEXTURE_CUBE_MAP, lighting.ggx_chain());
      const std::vector<SpecularLight>& lights = lighting.ggx_lights();
      if (!lights.empty()) {
        std::array<glm::vec3, kMaxSpecularLights> direction{}, power{}, disc{};
        for (std::size_t i = 0; i < lights.size(); ++i) {
          const float radius = lights[i].radius;
          direction[i] = lights[i].direction, power[i] = lights[i].power;
          disc[i] = {std::cos(radius), std::sin(radius), radius};
        }
        const GLsizei n = GLsizei(lights.size());
        glUniform1i(u.ggx_light_count, n);
        glUniform3fv(u.ggx_light_direction, n, glm::value_ptr(direction[0]));
        glUniform3fv(u.ggx_light_power, n, glm::value_ptr(power[0]));
        glUniform3fv(u.ggx_light_disc, n, glm::value_ptr(disc[0]));
      }
    }
  }
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
      glUniform1f(u.inv_exposure_gain, live->inv_exposure_gain);
      glActiveTexture(GL_TEXTURE0 + kFrame);
      glBindTexture(GL_TEXTURE_2D, live->frame_copy);
      glActiveTexture(GL_TEXTURE0 + kResponseInverse);
      glBindTexture(GL_TEXTURE_2D, live->response_inverse);
    }
  }
  if (transfer) {
    // The room's SH in the object's frame: L_obj(w) = L_world(world_from_object w).
    const ShCoeffs l =
        sh_rotate(lighting.room_sh(), glm::dmat3(world_from_object(st.world_from_scene, model)));
    std::array<glm::vec3, kTransferCoefficients> v;
    for (std::size_t k = 0; k < v.size(); ++k) v[k] = glm::vec3(l.c[k]);
    glUniform3fv(u.light_sh, GLsizei(v.size()), glm::value_ptr(v[0]));
  }
  if (hemisphere) {
    const HemispherePriors h = lighting.hemisphere_priors();
    glUniform3fv(u.sky, 1, glm::value_ptr(h.upper));
    glUniform3fv(u.ground, 1, glm::value_ptr(h.lower));
    // The occlusion factor's range, down to up: (shadow / light, 1), or none.
    const bool occlude = shading == Shading::HemisphereOcclusion && h.light > 0.0f;
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
  glBindTexture(GL_TEXTURE_2D, use_albedo ? texture_for(m.albedo) : white_tex_.id);
  glActiveTexture(GL_TEXTURE0 + kNormal);
  glBindTexture(GL_TEXTURE_2D, use_normal ? texture_for(m.normal_map) : flat_normal_tex_.id);
  glActiveTexture(GL_TEXTURE0 + kLight);
  glBindTexture(GL_TEXTURE_2D, use_light ? texture_for(m.light_map) : white_tex_.id);

  glBindVertexArray(mesh.vao());
  if (!mesh.has_uvs()) glVertexAttrib2f(2, 0.0f, 0.0f);
  if (!mesh.has_tangents()) glVertexAttrib4f(3, 1.0f, 0.0f, 0.0f, 1.0f);
  if (!mesh.has_occlusion()) glVertexAttrib4f(4, 0.0f, 0.0f, 0.0f, 1.0f);  // nothing baked
  glDrawElements(GL_TRIANGLES, GLsizei(part.index_count), GL_UNSIGNED_INT,
                 reinterpret_cast<const void*>(std::uintptr_t(part.first_index) * sizeof(std::uint32_t)));
  glBindVertexArray(0);
  glDisable(GL_BLEND);
  gl::check("draw");
}

}  // namespace arlight::render
