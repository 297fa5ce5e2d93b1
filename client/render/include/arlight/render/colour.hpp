// Colour priors and colour correction (dissertation §5.1, §5.6): statistics of the room and of
// the model that the compositing options of the renderer (ColourCorrection) match the virtual
// object to.
#pragma once

#include <cstdint>
#include <glm/mat3x3.hpp>
#include <glm/vec3.hpp>
#include <optional>
#include <string_view>
#include <vector>

#include "arlight/common/projection.hpp"
#include "arlight/render/material.hpp"
#include "arlight/render/mesh.hpp"

namespace arlight::render {

// Reinhard et al. 2004's linear approximation of CIELAB, "l alpha beta" (dissertation eq. 11a):
// lightness and two colour-opponent axes, linear in RGB (no logarithm, unlike Ruderman's space
// in Reinhard et al. 2001), so statistics scale with exposure. The dissertation's printed
// matrices lost their minus signs in print; these are the 2004 paper's forward matrix, and the
// inverse is computed from it (the printed inverse is its inverse only to 4e-4).
glm::mat3 lab_from_rgb();
glm::mat3 rgb_from_lab();

// Mean and standard deviation per l alpha beta channel.
struct ColourStats {
  glm::vec3 mean{0.0f}, sd{0.0f};
};

// The room's colour priors (§5.1), from its radiance: the horizontal regions (the directions
// whose largest component is horizontal: the four side faces of a cube map, as the
// dissertation took them), every texel weighted by its solid angle.
struct EnvironmentPriors {
  ColourStats lab;  // of the radiance
  // Greyscale priors (§5.1.2, BT.709 luma of linear radiance): the darkest and lightest of the
  // four sides' means (front -Z, right +X, back +Z, left -X) and the mean of all four.
  float grey_low = 0.0f, grey_mean = 0.0f, grey_high = 0.0f;
};
EnvironmentPriors environment_priors(const EnvMap& radiance);

// The texels of a width x height texture that the mesh's UV triangles cover (1) or not (0), row
// 0 at v = 0 (the top of the image, as TextureImage stores it); UVs repeat. This is the
// dissertation's "green screen" (§5.1.1, Fig. 13c) without editing the texture by hand. Empty
// when the mesh has no UVs.
std::vector<std::uint8_t> uv_coverage(const Mesh& mesh, int width, int height);

// The model's colour priors (§5.1.1): kd times its albedo texture (linear), over the texels the
// UVs cover; kd alone without a texture or UVs. nullopt when no texel is covered.
std::optional<ColourStats> model_priors(const Mesh& mesh, const Material& material);

// Dissertation §5.6, compositing options of the tone mapping (ToneMapping::colour).
enum class ColourCorrection {
  None,
  // §5.6.1.1, eq. 9: the object's pixel times an intensity between the room's darkest and
  // lightest side (the greyscale priors as the camera shows them), picked by the pixel's luma.
  Brightness,
  // §5.6.1.2, eqs. 10a/b: the same around the room's mean grey, biased contrast.
  Contrast,
  // §5.6.2, eq. 11b (Reinhard et al. 2001) in eq. 11a's space: the object's pixels, whose
  // statistics are measured over the mask each frame, get the room's mean and deviation.
  Match,
};
// "none", "brightness", "contrast", "match": the clients' names.
const char* colour_correction_name(ColourCorrection c);
std::optional<ColourCorrection> colour_correction_named(std::string_view name);

}  // namespace arlight::render
