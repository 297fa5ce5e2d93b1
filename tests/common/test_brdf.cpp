// The glTF metallic-roughness BRDF (common/brdf.hpp): reciprocity, energy against the DFG
// table's integrals, and the DFG table against its limits and Filament's cmgen.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <glm/geometric.hpp>
#include <numbers>
#include <string>

#include "arlight/common/brdf.hpp"
#include "arlight/common/hdr_io.hpp"

using namespace arlight;

namespace {

glm::dvec3 direction(double theta, double phi) {
  return {std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta)};
}

// The integral of f(l, v) n.l over the hemisphere of n = +z, midpoint rule in (cos theta, phi).
glm::dvec3 albedo(const glm::dvec3& v, const glm::dvec3& base, double metallic, double roughness,
                  int n = 800) {
  glm::dvec3 sum(0.0);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      const double c = (i + 0.5) / n, phi = 2 * std::numbers::pi * (j + 0.5) / n;
      const glm::dvec3 l = direction(std::acos(c), phi);
      sum += metallic_roughness_brdf({0, 0, 1}, l, v, base, metallic, roughness) * c;
    }
  return sum * (2 * std::numbers::pi / (double(n) * n));
}

}  // namespace

TEST(Brdf, IsReciprocalAndZeroBelowTheHorizon) {
  const glm::dvec3 n(0, 0, 1), l = direction(0.7, 0.3), v = direction(1.1, 2.0);
  const glm::dvec3 base(0.8, 0.5, 0.2);
  const glm::dvec3 a = metallic_roughness_brdf(n, l, v, base, 0.3, 0.4);
  const glm::dvec3 b = metallic_roughness_brdf(n, v, l, base, 0.3, 0.4);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(a[c], b[c], 1e-12 * a[c]);
  EXPECT_EQ(metallic_roughness_brdf(n, direction(1.7, 0), v, base, 0.3, 0.4), glm::dvec3(0.0));
}

// A white metal reflects, single-scattered, exactly the DFG table's b (its F0 = 1 term); a black
// dielectric the F0 = 0.04 mix of a and b: the BRDF and the table are one model.
TEST(Brdf, ItsAlbedoIsTheDfgTablesSplitSum) {
  for (double roughness : {0.3, 0.6, 1.0})
    for (double nv : {0.3, 0.7, 0.95}) {
      const glm::dvec3 v = direction(std::acos(nv), 0.0);
      const glm::vec2 ab = dfg_value(nv, roughness, 1 << 14);
      const double metal = albedo(v, glm::dvec3(1.0), 1.0, roughness).x;
      EXPECT_NEAR(metal, ab.y, 0.01 * ab.y) << "r " << roughness << " n.v " << nv;
      const double dielectric = albedo(v, glm::dvec3(0.0), 0.0, roughness).x;
      const double split = ab.x + (ab.y - ab.x) * 0.04;
      EXPECT_NEAR(dielectric, split, 0.02 * split) << "r " << roughness << " n.v " << nv;
    }
  // A white Lambertian dielectric loses to its specular only what the Fresnel term takes.
  const double white = albedo(direction(0.2, 0), glm::dvec3(1.0), 0.0, 1.0).x;
  EXPECT_GT(white, 0.9);
  EXPECT_LT(white, 1.02);
}

// Kulla & Conty's lobe gives back what single scattering loses: with it, a white metal's albedo
// is 1 at every view and roughness (the white furnace the reference renderer passes).
TEST(Brdf, TheMultipleScatteringLobeFillsTheWhiteFurnace) {
  for (double roughness : {0.3, 0.6, 1.0}) {
    const GgxMultipleScattering ms(roughness, 32, 2048);
    EXPECT_LT(ms.average_albedo(), roughness < 0.5 ? 1.0 : 0.95);
    for (double nv : {0.3, 0.7, 0.95}) {
      const glm::dvec3 v = direction(std::acos(nv), 0.0);
      double sum = albedo(v, glm::dvec3(1.0), 1.0, roughness).x;
      const int n = 400;
      for (int i = 0; i < n; ++i)  // f_ms depends on n.l only
        sum += ms.brdf((i + 0.5) / n, nv, glm::dvec3(1.0)).x * (i + 0.5) / n * 2 * std::numbers::pi / n;
      EXPECT_NEAR(sum, 1.0, 0.01) << "r " << roughness << " n.v " << nv;
    }
  }
}

TEST(Dfg, KnownLimits) {
  // A smooth surface (r -> 0) seen head-on reflects F0: a ~ 0, b ~ 1 (V = 1 / (4 n.l n.v)).
  const glm::vec2 smooth = dfg_value(1.0, 0.02);
  EXPECT_NEAR(smooth.x, 0.0, 1e-3);
  EXPECT_NEAR(smooth.y, 1.0, 2e-3);
  // At grazing view the Fresnel term takes over: a -> b.
  const glm::vec2 grazing = dfg_value(0.01, 0.05);
  EXPECT_GT(grazing.x / grazing.y, 0.9);
  // Rough surfaces lose energy to single scattering (what the compensation restores).
  EXPECT_LT(dfg_value(0.5, 1.0).y, 0.8);
}

TEST(Dfg, MatchesFilamentsCmgen) {
  // Issue 34: the table within 1 % of `cmgen --ibl-dfg --ibl-dfg-multiscatter` (Debian
  // libfilament-tools, installed by make deps).
  const auto dir = std::filesystem::temp_directory_path() / ("arlight_dfg_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const auto file = dir / "dfg.exr";
  const std::string cmd = "cmgen --ibl-dfg=" + file.string() + " --ibl-dfg-multiscatter >/dev/null 2>&1";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << "cmgen failed (is libfilament-tools installed?)";
  const LoadedImage cm = load_image(file);
  std::filesystem::remove_all(dir);
  ASSERT_EQ(cm.image.width(), 128);
  ASSERT_EQ(cm.image.height(), 128);
  // cmgen's row j holds roughness (128 - j + 0.5) / 128, clamped to 1 (CubemapIBL::DFG): one
  // row above the texel centre our table (and a bilinear lookup) uses, so the integrals are
  // compared at cmgen's roughness; the tables themselves differ by that row.
  double worst = 0, mean = 0;
  for (int j = 0; j < 128; ++j)
    for (int i = 0; i < 128; ++i) {
      const glm::vec3 theirs = cm.image.at(i, j);
      const glm::vec2 v = dfg_value((i + 0.5) / 128, std::min(1.0, (128 - j + 0.5) / 128));
      for (int c = 0; c < 2; ++c) {
        const double err = std::abs(double(v[c]) - theirs[c]);
        worst = std::max(worst, err);
        mean += err / (2 * 128 * 128);
      }
    }
  EXPECT_LT(worst, 0.005);
  EXPECT_LT(mean, 0.0005);
  // Our table's rows are at texel centres.
  const DfgTable ours = dfg_table(16, 256);
  EXPECT_EQ(ours.at(3, 5), dfg_value(3.5 / 16, 1.0 - 5.5 / 16, 256));
}
