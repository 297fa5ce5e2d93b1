// Real, orthonormal spherical harmonics of arbitrary order from normalized recurrences, their
// projection from and evaluation on environment maps, and the zonal coefficients of the
// normalized Phong lobe (thesis §2.4, Alg. 4.4-4.7). Conventions: common/CONVENTIONS.md.
//
// "Order" N means bands l = 0..N-1, N^2 coefficients, coefficient (l, m) at index l(l+1)+m.
#pragma once

#include <array>

#include <glm/mat3x3.hpp>
#include <glm/vec3.hpp>
#include <span>
#include <vector>

#include "arlight/common/image.hpp"
#include "arlight/common/projection.hpp"

namespace arlight {

constexpr int sh_index(int l, int m) { return l * (l + 1) + m; }
constexpr int sh_count(int order) { return order * order; }

// SH coefficients of an RGB function on the sphere.
struct ShCoeffs {
  int order = 0;
  std::vector<glm::dvec3> c;  // sh_count(order) entries

  ShCoeffs() = default;
  explicit ShCoeffs(int order_) : order(order_), c(std::size_t(sh_count(order_)), glm::dvec3(0)) {}
  glm::dvec3& at(int l, int m) { return c[std::size_t(sh_index(l, m))]; }
  const glm::dvec3& at(int l, int m) const { return c[std::size_t(sh_index(l, m))]; }
};

// All sh_count(order) basis values Y_l^m(dir) (dir need not be normalized).
void sh_basis_all(int order, glm::dvec3 dir, std::span<double> out);
// One basis value, in O(l) work.
double sh_basis(int l, int m, glm::dvec3 dir);

// Fully normalized associated Legendre functions P~_l^m(z), m >= 0, with
// Y_l^0 = P~_l^0(cos theta) and Y_l^{+-m} = sqrt(2) P~_l^m(cos theta) {cos, sin}(m phi).
// out[l(l+1)/2 + m] for 0 <= m <= l < order.
void sh_legendre(int order, double z, std::span<double> out);

// Projects an environment map onto SH (thesis eq. 2.29 / Alg. 4.5): c_lm = sum over valid
// texels of L * Y_lm(dir) * solid angle. Runs on all cores; accumulates in double.
ShCoeffs sh_project(const EnvMap& env, int order);

// Adds sum_i values[i] * Y_lm(dirs[i]) to every coefficient: an incremental projection, e.g. of
// the change of a few texels (values = change of radiance * solid angle). One thread.
void sh_accumulate(ShCoeffs& coeffs, std::span<const glm::dvec3> dirs,
                   std::span<const glm::dvec3> values);

// sum_lm c_lm Y_lm(dir)
glm::dvec3 sh_evaluate(const ShCoeffs& coeffs, glm::dvec3 dir);

// The single distant light that best explains bands 0-1 of `coeffs` (radiance SH): `direction`
// (unit, towards the light) is that of the luminance-weighted linear band, `colour` its
// intensity per channel by least squares (irradiance at normal incidence). An environment
// without a linear band (e.g. constant) gives colour 0 and direction +Y.
struct DominantLight {
  glm::vec3 direction{0.0f, 1.0f, 0.0f};
  glm::vec3 colour{0.0f};
};
DominantLight sh_dominant_light(const ShCoeffs& coeffs);

// SH-9 as WebXR's sphericalHarmonicsCoefficients and three.js's LightProbe.sh.fromArray take it:
// 27 floats, 9 RGB triples in index order l(l+1)+m — raw radiance coefficients on this real
// orthonormal basis without the Condon-Shortley phase (Y_1,-1 ~ y, Y_1,0 ~ z, Y_1,1 ~ x), in
// common/CONVENTIONS.md's frame. std::invalid_argument below order 3.
std::array<float, 27> sh9_webxr(const ShCoeffs& sh);

// Evaluates the expansion at every valid texel of `layout` (others stay 0). All cores.
Image sh_reconstruct(const ShCoeffs& coeffs, const EnvLayout& layout);

// Evaluates several expansions of one order at many directions, computing the basis once per
// direction: out[k][3 i + c] = sum_lm coeffs[k] (l, m)[c] Y_lm(dirs[i]). One thread; callers
// split the directions across cores.
void sh_evaluate_many(std::span<const ShCoeffs> coeffs, std::span<const glm::dvec3> dirs,
                      std::span<float* const> out);

// The expansion of the rotated function w -> L(r w) (r a rotation): e.g. a world-frame
// lighting's SH in an object's frame, r = world_from_object. Exact (quadrature over 2 N^2
// directions, N the order); throws for coefficients that do not match their order.
ShCoeffs sh_rotate(const ShCoeffs& coeffs, const glm::dmat3& r);

// Multiplies band l by zonal[l] (spherical convolution with a zonal kernel, thesis eq. 2.31,
// where zonal[l] already includes Lambda_l = sqrt(4 pi / (2l+1))).
ShCoeffs sh_convolve(const ShCoeffs& coeffs, std::span<const double> zonal);

// Lambda_l * rho_l of the normalized Phong lobe (s+1)/(2 pi) max(0, cos)^s (thesis eq. 2.33,
// Alg. 4.6), i.e. (s+1) * integral_0^1 t^s P_l(t) dt. s = 1 is the irradiance (clamped cosine)
// lobe. Exact for any real s >= 0 and band l; never overflows.
double phong_zonal(int l, double s);
std::vector<double> phong_zonal_all(int order, double s);

// The SH of the clamped cosine around unit n over pi, max(0, n.w) / pi: phong_zonal(l, 1)
// Y_lm(n) (1, 2/3 and 1/4 for bands 0-2), sh_count(order) values. Dotted with a radiance SH it
// gives the lobe-averaged radiance at n (the irradiance map's value); it is the transfer of a
// point nothing occludes (transfer.hpp).
std::vector<double> sh_cosine_lobe(glm::dvec3 n, int order);

// Gauss-Legendre nodes and weights on [-1, 1], exact for polynomials of degree <= 2n-1.
struct GaussLegendre {
  std::vector<double> x, w;
};
GaussLegendre gauss_legendre(int n);

}  // namespace arlight
