// Internal: the material pass. Draws a mesh into the HDR target shaded by the room's light:
// thesis Alg. 5.1-5.4 (irradiance and reflection maps, light and normal maps), dissertation
// §5.4's hemisphere shading, §5.5's glass, and the meshes' SH-9 transfer. Owns ibl.frag's
// variants (one per projection and feature set, compiled when first used) and the material
// textures' GPU copies.
#pragma once

#include <filesystem>
#include <memory>
#include <unordered_map>

#include "arlight/render/render.hpp"
#include "fullscreen_pass.hpp"
#include "scene_lighting.hpp"

namespace arlight::render {

// The camera frame live glass refracts (Refraction::LiveFrame): a copy of the output's frame,
// R, G, B (the browser's) or B, G, R, and what turns its codes back into radiance.
struct LiveFrameInputs {
  GLuint frame_copy;
  bool frame_rgb;
  GLuint response_inverse;
  float inv_exposure_gain;  // 1 / (exposure x gain) of the frame
};

// An object's rotation into the lighting's (world) frame: the model's scale taken out.
glm::mat3 world_from_object(const glm::mat3& world_from_scene, const glm::mat4& model);

class IblPass {
 public:
  // Compiles the common variant (diffuse + mixed specular, lat-long) now, so shader errors show
  // up at construction.
  explicit IblPass(const std::filesystem::path& shader_dir);
  ~IblPass();

  // The texture unit ibl.frag samples LiveFrameInputs::frame_copy from.
  static constexpr GLint kFrameUnit = 6;

  Shading shading = Shading::ImageBased;
  ReflectionLookup lookup = ReflectionLookup::Interpolate;

  // Draws the mesh's triangles of `part` into targets.hdr_fbo, depth tested; `live` for glass
  // showing the frame.
  void draw(const GpuMesh& mesh, const Material& material, const glm::mat4& model,
            const DrawState& state, const SceneLighting& lighting, const RenderTargets& targets,
            const MeshPart& part, const LiveFrameInputs* live = nullptr);
  // Zeroes radiance, coverage and mask where nothing has been drawn yet this frame (depth still
  // 1): what alpha-blended surfaces are blended over there (clear_uncovered.frag).
  void clear_uncovered(const RenderTargets& targets, const FullscreenPass& fullscreen);

 private:
  struct Variant;
  const Variant& variant(Projection projection, unsigned features);
  GLuint texture_for(const std::shared_ptr<const TextureImage>& image);

  std::filesystem::path shader_dir_;
  std::unordered_map<unsigned, Variant> variants_;  // by projection | features << 2
  struct CachedTexture {
    std::weak_ptr<const TextureImage> owner;
    gl::Texture tex;
  };
  std::unordered_map<const TextureImage*, CachedTexture> textures_;
  Program clear_uncovered_;  // made when first needed
  gl::Texture white_tex_, flat_normal_tex_;  // a material's missing albedo and normal map
  gl::Texture dfg_tex_;  // the split sum's DFG table, made for the first metallic-roughness draw
};

}  // namespace arlight::render
