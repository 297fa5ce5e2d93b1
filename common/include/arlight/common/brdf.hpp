// glTF 2.0 metallic-roughness's BRDF (glTF 2.0 Appendix B; Filament's "Physically Based
// Rendering in Filament"; Karis 2013): GGX (Trowbridge-Reitz) normal distribution, the
// height-correlated Smith visibility and Schlick's Fresnel, with roughness glTF's perceptual r
// (alpha = r^2). The renderer's shader (shaders/ibl.frag, METALLIC_ROUGHNESS), the reference
// renderer (sim/reference) and the split sum's DFG table share these definitions.
#pragma once

#include <cstdint>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>
#include <vector>

namespace arlight {

// The base-2 radical inverse of i (Van der Corput), the second coordinate of a Hammersley set.
inline double radical_inverse(std::uint32_t i) {
  i = (i << 16u) | (i >> 16u);
  i = ((i & 0x55555555u) << 1u) | ((i & 0xAAAAAAAAu) >> 1u);
  i = ((i & 0x33333333u) << 2u) | ((i & 0xCCCCCCCCu) >> 2u);
  i = ((i & 0x0F0F0F0Fu) << 4u) | ((i & 0xF0F0F0F0u) >> 4u);
  i = ((i & 0x00FF00FFu) << 8u) | ((i & 0xFF00FF00u) >> 8u);
  return double(i) * 0x1p-32;
}

// D(h) for n.h and a2 = alpha^2 (normalised: the integral of D n.h over the hemisphere is 1).
double ggx_distribution(double n_dot_h, double a2);
// V = G / (4 n.l n.v), height-correlated Smith (Heitz 2014; Filament's V_SmithGGXCorrelated).
double ggx_visibility(double n_dot_v, double n_dot_l, double a2);
// Schlick's Fresnel for F0 at v.h.
glm::dvec3 schlick_fresnel(const glm::dvec3& f0, double v_dot_h);
// The glTF metallic-roughness BRDF f(l, v) (per sr) for unit n, l, v, as glTF's Appendix B
// mixes it: (1 - metallic)(1 - F(0.04)) x Lambert of base, plus F(mix(0.04, base, metallic)) x
// the GGX specular (fresnel_mix, conductor_fresnel). 0 below either horizon.
glm::dvec3 metallic_roughness_brdf(const glm::dvec3& n, const glm::dvec3& l, const glm::dvec3& v,
                                   const glm::dvec3& base, double metallic, double roughness);

// The energy a GGX surface of one roughness loses to single scattering, given back as Kulla &
// Conty's multiple-scattering lobe ("Revisiting Physically Based Shading at Imageworks", 2017):
//   f_ms(l, v) = F_ms (1 - E(n.l)) (1 - E(n.v)) / (pi (1 - E_avg)),
// E the single-scattering albedo for F = 1 (the DFG table's b), E_avg = 2 integral E(mu) mu dmu,
// F_ms = F_avg^2 E_avg / (1 - F_avg (1 - E_avg)) with Schlick's average F_avg = (20 F0 + 1) / 21.
// A white metal with it reflects a constant room exactly (the reference renderer's "full BRDF";
// the renderer's split sum approximates it with Filament's 1 + F0 (1 / b - 1)).
class GgxMultipleScattering {
 public:
  explicit GgxMultipleScattering(double roughness, int table = 64, int samples = 1024);
  glm::dvec3 brdf(double n_dot_l, double n_dot_v, const glm::dvec3& f0) const;
  double albedo(double n_dot_v) const;  // E(mu), interpolated
  double average_albedo() const { return average_; }

 private:
  std::vector<double> albedo_;  // E at mu = (i + 0.5) / table
  double average_ = 1.0;
};

// The split sum's DFG term (Karis 2013; Filament's DFV_Multiscatter): for n.v = x and perceptual
// roughness y, the GGX BRDF's directional albedo split by the Schlick Fresnel as
//   a = integral of V * F_c,   b = integral of V,   F_c = (1 - v.h)^5,
// so the specular albedo for F0 is a + (b - a) F0 = mix(a, b, F0) and the multiple-scattering
// compensation 1 + F0 (1 / b - 1). Texel (i, j) of a size x size table holds
// x = (i + 0.5) / size and y = 1 - (j + 0.5) / size (row 0 is roughness 1, as cmgen writes it).
struct DfgTable {
  int size = 0;
  std::vector<glm::vec2> ab;  // row-major, (a, b) per texel
  glm::vec2 at(int i, int j) const { return ab[std::size_t(j) * std::size_t(size) + std::size_t(i)]; }
  // Row j's average albedo E_avg = 2 integral b(mu) mu dmu (the midpoint rule over the row's
  // texels), at most 1: Kulla & Conty's lobe needs it (GgxMultipleScattering).
  double average_albedo(int j) const;
};
// Importance-sampled with `samples` Hammersley points of the GGX distribution per texel, on one
// thread (the browser's build has no threads for it; 64 x 64 at 512 samples takes ~0.05 s).
// Throws InputError for a size outside [1, 4096] or samples < 1.
DfgTable dfg_table(int size = 128, int samples = 1024);
// One texel's (a, b) for n.v and perceptual roughness.
glm::vec2 dfg_value(double n_dot_v, double roughness, int samples = 1024);

}  // namespace arlight
