#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <cmath>
#include <cstdio>
#include <glm/geometric.hpp>
#include <glm/gtc/matrix_transform.hpp>
#include <numbers>
#include <random>

#include "../support/env_fixtures.hpp"
#include "arlight/common/sh.hpp"

using namespace arlight;

namespace {

constexpr double kPi = std::numbers::pi;

glm::dvec3 random_dir(std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0), a(0.0, 2 * kPi);
  const double z = u(rng), phi = a(rng), r = std::sqrt(1 - z * z);
  return {r * std::cos(phi), r * std::sin(phi), z};
}

// Unnormalized Legendre polynomial P_l(x) by the three-term recurrence.
double legendre(int l, double x) {
  double p0 = 1.0, p1 = x;
  if (l == 0) return p0;
  for (int k = 2; k <= l; ++k) {
    const double p2 = ((2.0 * k - 1.0) * x * p1 - (k - 1.0) * p0) / k;
    p0 = p1, p1 = p2;
  }
  return p1;
}

}  // namespace

TEST(ShBasis, MatchesTheClosedFormsOfTheFirstBands) {
  std::mt19937_64 rng(1);
  for (int i = 0; i < 50; ++i) {
    const glm::dvec3 d = random_dir(rng);
    const double x = d.x, y = d.y, z = d.z;
    const double want[9] = {0.5 / std::sqrt(kPi),
                            std::sqrt(3 / (4 * kPi)) * y,
                            std::sqrt(3 / (4 * kPi)) * z,
                            std::sqrt(3 / (4 * kPi)) * x,
                            0.5 * std::sqrt(15 / kPi) * x * y,
                            0.5 * std::sqrt(15 / kPi) * y * z,
                            0.25 * std::sqrt(5 / kPi) * (3 * z * z - 1),
                            0.5 * std::sqrt(15 / kPi) * x * z,
                            0.25 * std::sqrt(15 / kPi) * (x * x - y * y)};
    double got[9];
    sh_basis_all(3, d * 3.0, got);  // need not be normalized
    for (int k = 0; k < 9; ++k) EXPECT_NEAR(got[k], want[k], 1e-14) << "index " << k;
  }
}

TEST(ShBasis, RejectsBadArguments) {
  EXPECT_THROW(sh_basis(3, 4, {0, 0, 1}), std::invalid_argument);
  EXPECT_THROW(sh_basis(1, 0, {0, 0, 0}), std::invalid_argument);
  double out[4];
  EXPECT_THROW(sh_basis_all(0, {0, 0, 1}, out), std::invalid_argument);
  EXPECT_THROW(sh_basis_all(3, {0, 0, 1}, out), std::invalid_argument);  // span too small
}

TEST(ShOrthonormality, FullGramMatrixToOrder32IsTheIdentity) {
  // Gauss-Legendre in cos(theta) x uniform phi is exact for the products of bands < 32.
  const int order = 32, n = sh_count(order);
  const GaussLegendre gl = gauss_legendre(order + 1);
  const int n_phi = 2 * order;
  // cols[a][p] = sqrt(w_p) Y_a(p), so each Gram entry is a contiguous dot product.
  std::vector<std::vector<double>> cols(static_cast<std::size_t>(n));
  std::vector<double> y(static_cast<std::size_t>(n));
  for (std::size_t i = 0; i < gl.x.size(); ++i)
    for (int j = 0; j < n_phi; ++j) {
      const double z = gl.x[i], r = std::sqrt(1 - z * z), phi = 2 * kPi * (j + 0.5) / n_phi;
      sh_basis_all(order, {r * std::cos(phi), r * std::sin(phi), z}, y);
      const double sw = std::sqrt(gl.w[i] * 2 * kPi / n_phi);
      for (int a = 0; a < n; ++a) cols[std::size_t(a)].push_back(sw * y[std::size_t(a)]);
    }
  const std::size_t points = cols[0].size();
  double worst = 0;
  for (int a = 0; a < n; ++a)
    for (int b = a; b < n; ++b) {
      const double* u = cols[std::size_t(a)].data();
      const double* v = cols[std::size_t(b)].data();
      double g[4] = {0, 0, 0, 0};
      std::size_t p = 0;
      for (; p + 4 <= points; p += 4)
        for (int k = 0; k < 4; ++k) g[k] += u[p + k] * v[p + k];
      for (; p < points; ++p) g[0] += u[p] * v[p];
      const double dot = (g[0] + g[1]) + (g[2] + g[3]);
      worst = std::max(worst, std::abs(dot - (a == b ? 1.0 : 0.0)));
    }
  EXPECT_LT(worst, 1e-12);
  std::printf("Gram matrix to order 32: max |G - I| = %.3g\n", worst);
}

TEST(ShOrthonormality, EveryMOfHighBandsTo256) {
  // <Y_l^m, Y_l'^m> = 2 pi * integral P~_l^m P~_l'^m dz (the phi integral of cos^2 or sin^2 is
  // pi, times the sqrt(2)^2). Checked for every m of several l up to 255 against the same m
  // of the two bands below (the pairs a recurrence gets wrong first).
  const int order = 256;
  const GaussLegendre gl = gauss_legendre(order + 1);
  std::vector<std::vector<double>> p(gl.x.size(),
                                     std::vector<double>(std::size_t(order) * (order + 1) / 2));
  for (std::size_t i = 0; i < gl.x.size(); ++i) sh_legendre(order, gl.x[i], p[i]);
  auto inner = [&](int l1, int l2, int m) {
    double s = 0;
    for (std::size_t i = 0; i < gl.x.size(); ++i)
      s += gl.w[i] * p[i][std::size_t(l1) * (l1 + 1) / 2 + m] *
           p[i][std::size_t(l2) * (l2 + 1) / 2 + m];
    return 2 * kPi * s;
  };
  double worst = 0;
  int pairs = 0;
  for (int l : {35, 86, 128, 200, 255})
    for (int m = 0; m <= l; ++m) {
      worst = std::max(worst, std::abs(inner(l, l, m) - 1.0));
      for (int k : {1, 2, 7})
        if (l - k >= m) worst = std::max(worst, std::abs(inner(l, l - k, m))), ++pairs;
    }
  EXPECT_LT(worst, 1e-8);
  EXPECT_GT(pairs, 1500);
  std::printf("%d same-m pairs to band 255: max error %.3g\n", pairs, worst);
}

TEST(ShOrthonormality, RandomPairsTo256ByFullSphereQuadrature) {
  std::mt19937_64 rng(7);
  std::uniform_int_distribution<int> band(0, 255);
  struct Pair {
    int l1, m1, l2, m2;
  };
  std::vector<Pair> pairs = {
      {255, 255, 255, 255}, {255, -200, 255, -200}, {254, 3, 250, 3}, {255, 0, 253, 0}};
  for (int i = 0; i < 6; ++i) {
    const int l1 = band(rng), l2 = band(rng);
    const int m1 = std::uniform_int_distribution<int>(-l1, l1)(rng);
    const int m2 =
        (i % 2 == 0 && std::abs(m1) <= l2) ? m1 : std::uniform_int_distribution<int>(-l2, l2)(rng);
    pairs.push_back({l1, m1, l2, m2});
  }
  for (const Pair& pr : pairs) {
    const int lmax = std::max(pr.l1, pr.l2);
    const GaussLegendre gl = gauss_legendre(lmax + 1);
    const int n_phi = 2 * lmax + 2;
    double s = 0;
    for (std::size_t i = 0; i < gl.x.size(); ++i)
      for (int j = 0; j < n_phi; ++j) {
        const double z = gl.x[i], r = std::sqrt(1 - z * z), phi = 2 * kPi * (j + 0.5) / n_phi;
        const glm::dvec3 d(r * std::cos(phi), r * std::sin(phi), z);
        s += gl.w[i] * (2 * kPi / n_phi) * sh_basis(pr.l1, pr.m1, d) * sh_basis(pr.l2, pr.m2, d);
      }
    const double want = (pr.l1 == pr.l2 && pr.m1 == pr.m2) ? 1.0 : 0.0;
    EXPECT_NEAR(s, want, 1e-8) << "(" << pr.l1 << "," << pr.m1 << ") x (" << pr.l2 << "," << pr.m2
                               << ")";
  }
}

TEST(ShStability, NoOverflowOrNaNToOrder512AndTheAdditionTheoremHolds) {
  // sum_m Y_lm(d)^2 = (2l+1) / (4 pi) for every direction: a check of every band's scale.
  const int order = 512;
  std::vector<double> y(std::size_t(sh_count(order)));
  std::mt19937_64 rng(3);
  std::vector<glm::dvec3> dirs = {{0, 0, 1},    {0, 0, -1},    {1, 0, 0},        {0, 1, 0},
                                  {1e-9, 0, 1}, {0, 1e-5, -1}, {0.6, 0.8, 1e-13}};
  for (int i = 0; i < 8; ++i) dirs.push_back(random_dir(rng));
  for (const glm::dvec3& d : dirs) {
    sh_basis_all(order, d, y);
    for (double v : y) ASSERT_TRUE(std::isfinite(v));
    for (int l = 0; l < order; ++l) {
      double s = 0;
      for (int m = -l; m <= l; ++m)
        s += y[std::size_t(sh_index(l, m))] * y[std::size_t(sh_index(l, m))];
      ASSERT_NEAR(s / ((2 * l + 1) / (4 * kPi)), 1.0, 1e-9) << "band " << l;
    }
  }
}

TEST(ShBasis, SingleAllAndLegendreAgree) {
  std::mt19937_64 rng(5);
  const int order = 256;
  std::vector<double> all(std::size_t(sh_count(order))), leg(std::size_t(order) * (order + 1) / 2);
  for (int i = 0; i < 4; ++i) {
    const glm::dvec3 d = random_dir(rng);
    sh_basis_all(order, d, all);
    sh_legendre(order, d.z, leg);
    const double phi = std::atan2(d.y, d.x);
    for (int l : {0, 1, 17, 128, 255})
      for (int m = -l; m <= l; ++m) {
        const double single = sh_basis(l, m, d);
        const double p = leg[std::size_t(l) * (l + 1) / 2 + std::size_t(std::abs(m))];
        const double from_legendre =
            m == 0 ? p : std::sqrt(2.0) * p * (m > 0 ? std::cos(m * phi) : std::sin(-m * phi));
        ASSERT_NEAR(all[std::size_t(sh_index(l, m))], single, 1e-12) << l << "," << m;
        ASSERT_NEAR(single, from_legendre, 1e-10) << l << "," << m;
      }
  }
}

// --- projection and reconstruction ------------------------------------------------------------

TEST(ShProject, ConstantGivesOnlyTheDcTerm) {
  const EnvMap env = test::env_from_function(EnvLayout::for_size(Projection::AngleMap, 256),
                                             [](glm::dvec3) { return glm::vec3(1, 2, 3); });
  const ShCoeffs c = sh_project(env, 8);
  const double dc = std::sqrt(4 * kPi);
  EXPECT_NEAR(c.at(0, 0).x, 1 * dc, 1e-9);  // exact solid angles: 4 pi to rounding
  EXPECT_NEAR(c.at(0, 0).z, 3 * dc, 1e-9);
  for (int k = 1; k < sh_count(8); ++k) EXPECT_LT(glm::length(c.c[std::size_t(k)]), 2e-3) << k;
}

TEST(ShProject, SingleBasisFunctionIsRecovered) {
  for (Projection p : {Projection::AngleMap, Projection::LatLong, Projection::Cube}) {
    const EnvMap env = test::env_from_function(EnvLayout::for_size(p, 256), [](glm::dvec3 d) {
      return glm::vec3(float(sh_basis(5, -3, d)));
    });
    const ShCoeffs c = sh_project(env, 10);
    for (int l = 0; l < 10; ++l)
      for (int m = -l; m <= l; ++m)
        EXPECT_NEAR(c.at(l, m).x, (l == 5 && m == -3) ? 1.0 : 0.0, 2e-3)
            << projection_name(p) << " " << l << "," << m;
  }
}

TEST(ShProject, ClampedCosineMatchesFunkHecke) {
  // max(0, n.d) has c_lm = pi * phong_zonal(l, 1) * Y_lm(n) (Funk-Hecke).
  const glm::dvec3 n = glm::normalize(glm::dvec3(0.3, -0.5, 0.8));
  const EnvMap env = test::env_from_function(
      EnvLayout::for_size(Projection::LatLong, 512),
      [&](glm::dvec3 d) { return glm::vec3(float(std::max(0.0, glm::dot(n, d)))); });
  const ShCoeffs c = sh_project(env, 8);
  for (int l = 0; l < 8; ++l)
    for (int m = -l; m <= l; ++m)
      EXPECT_NEAR(c.at(l, m).x, kPi * phong_zonal(l, 1.0) * sh_basis(l, m, n), 1e-3)
          << l << "," << m;
  EXPECT_NEAR(c.at(0, 0).x, std::sqrt(kPi) / 2, 1e-4);
}

TEST(ShDominantLight, FindsASmallBrightSourceOverASkyAndItsIrradiance) {
  // A uniform sky of 0.2 plus a disc of radiance (50, 40, 30) and 5 degrees radius at d: the
  // dominant light points at d and its colour is the disc's irradiance at normal incidence,
  // L * 2 pi (1 - cos 5 deg) (the sky has no linear band).
  const glm::dvec3 d = glm::normalize(glm::dvec3(0.4, 0.7, -0.3));
  const double cos_r = std::cos(5.0 * kPi / 180);
  const glm::vec3 radiance(50, 40, 30);
  const EnvMap env =
      test::env_from_function(EnvLayout::for_size(Projection::LatLong, 1024), [&](glm::dvec3 w) {
        return glm::vec3(0.2f) + (glm::dot(w, d) > cos_r ? radiance : glm::vec3(0.0f));
      });
  const DominantLight light = sh_dominant_light(sh_project(env, 3));
  EXPECT_LT(std::acos(std::min(1.0, glm::dot(glm::dvec3(light.direction), d))) * 180 / kPi, 0.5);
  // The disc's cosine-weighted solid angle is within 0.2 % of its solid angle at 5 degrees.
  const double omega = 2 * kPi * (1 - cos_r);
  for (int c = 0; c < 3; ++c)
    EXPECT_NEAR(light.colour[c], radiance[c] * omega, 0.01 * radiance[c] * omega) << c;
  // A constant environment has no dominant light.
  const DominantLight none = sh_dominant_light(
      sh_project(test::env_from_function(EnvLayout::for_size(Projection::LatLong, 128),
                                         [](glm::dvec3) { return glm::vec3(1.0f); }),
                 3));
  EXPECT_LT(glm::length(none.colour), 1e-3f);
}

TEST(ShProject, IndependentOfTheThreadCount) {
  const EnvMap env =
      test::env_from_function(EnvLayout::for_size(Projection::AngleMap, 96), [](glm::dvec3 d) {
        return glm::vec3(float(std::exp(3 * d.x)), float(d.y * d.y), float(1 + d.z));
      });
  const ShCoeffs all_cores = sh_project(env, 12);
  ShCoeffs one_core;
  {
    tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
    one_core = sh_project(env, 12);
  }
  for (std::size_t k = 0; k < all_cores.c.size(); ++k)
    ASSERT_EQ(all_cores.c[k], one_core.c[k]) << k;
}

TEST(ShReconstruct, MatchesPointEvaluationAndRecoversBandLimitedMaps) {
  ShCoeffs c(12);
  std::mt19937_64 rng(9);
  std::normal_distribution<double> g;
  for (auto& v : c.c) v = {g(rng), g(rng), g(rng)};
  const EnvLayout l = EnvLayout::for_size(Projection::Cube, 24);
  const Image img = sh_reconstruct(c, l);
  for (int y = 0; y < l.height(); y += 5)
    for (int x = 0; x < l.width(); x += 3) {
      const glm::dvec3 want = sh_evaluate(c, l.texel_dir(x, y));
      ASSERT_NEAR(img.at(x, y).x, want.x, 1e-4 * (1 + std::abs(want.x)));
      ASSERT_NEAR(img.at(x, y).z, want.z, 1e-4 * (1 + std::abs(want.z)));
    }
  // Projecting the reconstruction (fine lat-long) gives the coefficients back.
  const EnvLayout fine = EnvLayout::for_size(Projection::LatLong, 256);
  const ShCoeffs back = sh_project(EnvMap(fine, sh_reconstruct(c, fine)), 12);
  for (std::size_t k = 0; k < c.c.size(); ++k) EXPECT_NEAR(back.c[k].y, c.c[k].y, 2e-3) << k;
}

TEST(ShConvolve, ScalesEachBand) {
  ShCoeffs c(3);
  for (auto& v : c.c) v = glm::dvec3(1.0);
  const std::vector<double> zonal = {1.0, 0.5, 0.25};
  const ShCoeffs out = sh_convolve(c, zonal);
  EXPECT_EQ(out.at(0, 0).x, 1.0);
  EXPECT_EQ(out.at(1, -1).x, 0.5);
  EXPECT_EQ(out.at(2, 2).x, 0.25);
  EXPECT_THROW(sh_convolve(c, std::vector<double>{1.0}), std::invalid_argument);
}

// --- Phong lobe ---------------------------------------------------------------------------------

TEST(PhongZonal, KnownValuesOfTheClampedCosine) {
  EXPECT_DOUBLE_EQ(phong_zonal(0, 1), 1.0);
  EXPECT_DOUBLE_EQ(phong_zonal(1, 1), 2.0 / 3.0);
  EXPECT_DOUBLE_EQ(phong_zonal(2, 1), 1.0 / 4.0);
  EXPECT_DOUBLE_EQ(phong_zonal(3, 1), 0.0);
  EXPECT_NEAR(phong_zonal(4, 1), -1.0 / 24.0, 1e-17);
}

TEST(PhongZonal, MatchesNumericalIntegrationToBand200) {
  // (s+1) * integral_0^1 t^s P_l(t) dt by Gauss-Legendre on [0, 1] with 800 nodes: exact for
  // the polynomial t^s P_l(t) of degree <= 1480.
  const GaussLegendre gl = gauss_legendre(800);
  for (double s : {1.0, 10.0, 80.0, 1280.0})
    for (int l = 0; l <= 200; ++l) {
      double integral = 0;
      for (std::size_t i = 0; i < gl.x.size(); ++i) {
        const double t = 0.5 * (gl.x[i] + 1.0);
        integral += 0.5 * gl.w[i] * std::pow(t, s) * legendre(l, t);
      }
      const double want = (s + 1) * integral;
      const double got = phong_zonal(l, s);
      ASSERT_TRUE(std::isfinite(got));
      ASSERT_NEAR(got, want, 1e-12) << "s=" << s << " l=" << l;
    }
  // Wide lobes die off fast, narrow ones slowly (Ramamoorthi-Hanrahan: ~exp(-l^2 / 2s)).
  EXPECT_LT(std::abs(phong_zonal(40, 10)), 1e-3);
  EXPECT_GT(phong_zonal(40, 1280), 0.5);
}

TEST(GaussLegendre, ExactForPolynomialsOfDegreeBelow2n) {
  for (int n : {1, 2, 5, 33, 257}) {
    const GaussLegendre g = gauss_legendre(n);
    for (int k = 0; k <= 2 * n - 1; k += std::max(1, n / 8)) {
      double s = 0;
      for (std::size_t i = 0; i < g.x.size(); ++i) s += g.w[i] * std::pow(g.x[i], k);
      ASSERT_NEAR(s, k % 2 ? 0.0 : 2.0 / (k + 1), 1e-13) << n << " " << k;
    }
  }
}

// A rotated expansion evaluates at w to what the original does at r w, for random rotations
// and orders 1..5; rotating back restores the coefficients; bad input is refused.
TEST(ShRotate, EvaluatesTheOriginalAtTheRotatedDirection) {
  std::mt19937_64 rng(7);
  std::normal_distribution<double> gauss;
  for (int order = 1; order <= 5; ++order) {
    ShCoeffs sh(order);
    for (glm::dvec3& c : sh.c) c = {gauss(rng), gauss(rng), gauss(rng)};
    const glm::dvec3 axis = random_dir(rng);
    const double angle = 0.3 + order;
    const glm::dmat3 r = glm::dmat3(glm::rotate(glm::dmat4(1.0), angle, axis));
    const ShCoeffs rotated = sh_rotate(sh, r);
    for (int i = 0; i < 20; ++i) {
      const glm::dvec3 w = random_dir(rng);
      const glm::dvec3 want = sh_evaluate(sh, r * w), got = sh_evaluate(rotated, w);
      for (int c = 0; c < 3; ++c) EXPECT_NEAR(got[c], want[c], 1e-12) << "order " << order;
    }
    const ShCoeffs back = sh_rotate(rotated, glm::transpose(r));
    for (std::size_t k = 0; k < sh.c.size(); ++k)
      for (int c = 0; c < 3; ++c) EXPECT_NEAR(back.c[k][c], sh.c[k][c], 1e-12);
  }
  ShCoeffs bad(3);
  bad.c.pop_back();
  EXPECT_THROW(sh_rotate(bad, glm::dmat3(1.0)), std::invalid_argument);
}

// The clamped-cosine lobe's SH dotted with a radiance SH is the irradiance map's value at n
// (the zonal convolution, thesis eq. 2.33 at s = 1, evaluated there).
TEST(ShCosineLobe, DottedWithARoomIsItsIrradianceOverPi) {
  std::mt19937_64 rng(3);
  std::normal_distribution<double> gauss;
  ShCoeffs room(3);
  for (glm::dvec3& c : room.c) c = {gauss(rng), gauss(rng), gauss(rng)};
  const ShCoeffs irradiance = sh_convolve(room, phong_zonal_all(3, 1.0));
  for (int i = 0; i < 10; ++i) {
    const glm::dvec3 n = random_dir(rng);
    const std::vector<double> lobe = sh_cosine_lobe(n, 3);
    ASSERT_EQ(lobe.size(), 9u);
    glm::dvec3 dot(0.0);
    for (std::size_t k = 0; k < lobe.size(); ++k) dot += room.c[k] * lobe[k];
    const glm::dvec3 want = sh_evaluate(irradiance, n);
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(dot[c], want[c], 1e-12);
  }
}
