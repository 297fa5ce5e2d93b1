// Internal: uploads of environment maps, material textures and the camera-response table.
#pragma once

#include <array>
#include <cstdint>
#include <glm/vec2.hpp>
#include <vector>

#include "arlight/common/brdf.hpp"
#include "arlight/common/projection.hpp"
#include "arlight/common/response.hpp"
#include "arlight/render/material.hpp"
#include "gl.hpp"

namespace arlight::render {

// GL target of an environment map of this projection: TEXTURE_2D, or TEXTURE_CUBE_MAP for cube
// maps (faces +X, -X, +Y, -Y, +Z, -Z from the stacked image, common/CONVENTIONS.md).
GLenum env_target(Projection p);
// Uploads (or re-uploads in place, when the size is unchanged) an environment map as RGB16F,
// bilinear, no mipmaps (the maps are already filtered by their lobes). Lat-long wraps in u and
// clamps in v; angle maps clamp; cube maps sample seamlessly across faces (ES 3 always does).
void upload_env(const EnvMap& env, gl::Texture& tex, int& width, int& height);

// Uploads a GGX chain (cube maps, level k of face face0 >> k) as one RGBA16F cube map whose mip
// level k is the chain's level k: trilinear, GL_TEXTURE_MAX_LEVEL = levels - 1 (the chain
// needs no 1 x 1 level), so textureLod(chain, r, lod) blends neighbouring roughness as engines do.
gl::Texture upload_ggx_chain(const std::vector<EnvMap>& levels);
// The split sum's DFG table as an RGBA16F texture (x: n.v, y: 1 - roughness), bilinear, clamped:
// (a, b) in R and G, and in B each row's average albedo E_avg = 2 integral b(mu) mu dmu (Kulla &
// Conty's multiple-scattering lobe needs it).
gl::Texture upload_dfg(const DfgTable& table);

// A 1 x 1 RGBA8 texture of one colour, nearest, repeating: a material's missing texture.
gl::Texture upload_pixel_texture(std::array<std::uint8_t, 4> rgba);

// Uploads a material texture as RGBA8 / SRGB8_ALPHA8 (8-bit) or RGBA16F (float), with mipmaps,
// trilinear, repeating.
gl::Texture upload_material_texture(const TextureImage& image);

// The camera response's encode function per channel, sampled at x = (i / (n-1))^2 for
// i = 0..n-1 (dense near black, where sRGB is steep), into an n x 1 RGBA32F texture (nearest;
// the shader interpolates linearly between entries). Code value in [0, 1] per channel.
constexpr int kResponseLutSize = 1024;
void upload_response_lut(const CameraResponse& response, gl::Texture& tex);
// Its inverse: the linear exposure of each of the 256 codes per channel (CameraResponse::linear),
// a 256 x 1 RGBA32F texture (nearest; the shader interpolates between codes).
void upload_response_inverse(const CameraResponse& response, gl::Texture& tex);

}  // namespace arlight::render
