// The mesh's occlusion of itself, baked (tutorial §6.1; render::bake_occlusion) and shaded: the
// diffuse light comes along the bent normal, scaled by the ambient occlusion.
#include <cstdio>
#include <numbers>

#include "arlight/common/sh.hpp"
#include "arlight/render/transfer.hpp"
#include "render_fixtures.hpp"

namespace arlight::render {
namespace {

using namespace testing;

constexpr int W = SphereScene::W, H = SphereScene::H;

// Every map L(d) = a + g.d (grey).
void set_gradient_maps(Renderer& r, double a, glm::dvec3 g) {
  const EnvLayout layout = EnvLayout::for_size(Projection::LatLong, 64);
  EnvMap env(layout);
  for (int y = 0; y < layout.height(); ++y)
    for (int x = 0; x < layout.width(); ++x)
      env.image.set(x, y, glm::vec3(float(a + glm::dot(g, layout.texel_dir(x, y)))));
  r.set_maps({1.0, 64.0}, {env, env});
}

HdrReadback render_mesh(SphereScene& s, const Mesh& mesh, const Material& m) {
  const GpuMesh gpu(mesh);
  s.r.begin_frame();
  s.r.draw(gpu, m, glm::mat4(1.0f));
  return s.r.read_hdr();
}

// Occlusion given by hand (bent normals leaning by a known vector, 60 % open): each pixel is
// 0.6 x the gradient room's irradiance along the leaning normal, not along the surface normal.
TEST(BakedOcclusion, DiffuseLightComesAlongTheBentNormalScaledByTheOcclusion) {
  SphereScene s(64, 128);
  const double a = 2.0, open = 0.6;
  const glm::dvec3 g(0.6, 0.8, 0.3), lean(0.5, -0.4, 0.0);
  set_gradient_maps(s.r, a, g);
  Mesh mesh = make_sphere(float(SphereScene::kRadius), 64, 128);
  for (const glm::vec3& n : mesh.normals)
    mesh.occlusion.push_back(glm::vec4(glm::normalize(glm::dvec3(n) + lean), open));
  Material m;
  m.kd = glm::vec3(1.0f);
  const HdrReadback hdr = render_mesh(s, mesh, m);
  int checked = 0;
  double max_change = 0;
  for (int y = 0; y < H; y += 2)
    for (int x = 0; x < W; x += 2) {
      const auto p = s.hit(x, y);
      if (!p) continue;
      const glm::dvec3 n = glm::normalize(*p);
      if (n.z < 0.6) continue;  // away from the silhouette
      const double want = open * (a + glm::dot(g, glm::normalize(n + lean)));
      const double plain = a + glm::dot(g, n);
      ASSERT_NEAR(hdr.radiance.at(x, y).g, want, 0.01) << x << "," << y;
      max_change = std::max(max_change, std::abs(want - plain));
      ++checked;
    }
  EXPECT_GT(checked, 300);
  EXPECT_GT(max_change, 0.8);  // a missing occlusion or bent normal would be seen
}

// A convex mesh hides nothing from itself: its bake is all open with the bent normals on the
// normals (no ray meets the vertex's own triangles), and it shades as if nothing was baked.
TEST(BakedOcclusion, AConvexMeshBakesToNothingHiddenAndShadesUnchanged) {
  SphereScene s(48, 96);
  set_gradient_maps(s.r, 2.0, {0.6, 0.8, 0.3});
  Mesh mesh = make_sphere(float(SphereScene::kRadius), 48, 96);
  Material m;
  m.kd = glm::vec3(0.8f);
  m.ks = glm::vec3(0.2f);
  const HdrReadback plain = render_mesh(s, mesh, m);
  bake_occlusion(mesh, 1024);
  ASSERT_EQ(mesh.occlusion.size(), mesh.vertex_count());
  for (std::size_t i = 0; i < mesh.vertex_count(); ++i) {
    ASSERT_GT(mesh.occlusion[i].w, 0.995f) << i;
    ASSERT_GT(glm::dot(glm::vec3(mesh.occlusion[i]), mesh.normals[i]), 0.999f) << i;
  }
  const HdrReadback baked = render_mesh(s, mesh, m);
  int n = 0;
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      if (s.inside(x, y) != 1) continue;
      ++n;
      ASSERT_NEAR(baked.radiance.at(x, y).g, plain.radiance.at(x, y).g,
                  6e-3 * plain.radiance.at(x, y).g)
          << x << "," << y;
    }
  EXPECT_GT(n, 3000);
}

// The bunny's creases (between the legs and the body, inside the ears) are hidden from much of
// the room; its back is open. In a constant room a diffuse bunny's pixels are the room's
// radiance times the occlusion, so baking darkens the creases and leaves the back as it was.
TEST(BakedOcclusion, TheBunnysCreasesAreDarkenedAndItsOpenSideIsNot) {
  Mesh bunny = load_gltf(std::filesystem::path(ARLIGHT_ASSETS_DIR) / "models" / "bunny.glb");
  bake_occlusion(bunny);
  std::vector<float> ao;
  for (const glm::vec4& o : bunny.occlusion) ao.push_back(o.w);
  std::sort(ao.begin(), ao.end());
  EXPECT_LT(ao[ao.size() / 100], 0.6f);  // the most hidden 1 %
  EXPECT_GT(ao[ao.size() / 2], 0.9f);    // the median vertex sees most of its hemisphere
  // The topmost vertex (the ears' tips, or the back) is open.
  const auto top =
      std::max_element(bunny.positions.begin(), bunny.positions.end(),
                       [](const glm::vec3& p, const glm::vec3& q) { return p.y < q.y; });
  EXPECT_GT(bunny.occlusion[std::size_t(top - bunny.positions.begin())].w, 0.8f);
}

// Thesis Alg. 5.2's light map baked: a floor quad (its UVs its x and z) under a ball whose UVs
// cover nothing. Each texel is its floor point's ambient occlusion, 1 - r^2 h / D^3 under a ball
// of radius r with its centre h above the floor at distance D (the form factor of a sphere).
TEST(BakedLightMap, AFloorUnderABallHoldsTheFormFactorsOcclusion) {
  Mesh m;
  m.positions = {{-2, 0, -2}, {2, 0, -2}, {2, 0, 2}, {-2, 0, 2}};
  m.normals.assign(4, glm::vec3(0, 1, 0));
  m.uvs = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
  m.indices = {0, 2, 1, 0, 3, 2};
  const float r = 0.5f, h = 1.0f;
  const Mesh ball = make_sphere(r, 48, 96);
  const auto base = std::uint32_t(m.positions.size());
  for (std::size_t i = 0; i < ball.positions.size(); ++i) {
    m.positions.push_back(ball.positions[i] + glm::vec3(0, h, 0));
    m.normals.push_back(ball.normals[i]);
    m.uvs.push_back({0.5f, 0.5f});  // no UV area: the ball gets no texels
  }
  for (const std::uint32_t i : ball.indices) m.indices.push_back(base + i);
  constexpr int kSize = 48;
  const std::vector<float> ao = bake_light_map(m, kSize, kSize, 4096);
  ASSERT_EQ(ao.size(), std::size_t(kSize * kSize));
  double worst = 0, darkest = 1;
  for (int y = 0; y < kSize; ++y)
    for (int x = 0; x < kSize; ++x) {
      const double px = (x + 0.5) / kSize * 4.0 - 2.0, pz = (y + 0.5) / kSize * 4.0 - 2.0;
      const double d2 = px * px + pz * pz + double(h) * h;
      const double want = 1.0 - double(r) * r * h / (d2 * std::sqrt(d2));
      const double got = ao[std::size_t(y) * kSize + std::size_t(x)];
      worst = std::max(worst, std::abs(got - want));
      darkest = std::min(darkest, got);
    }
  EXPECT_LT(worst, 0.012);
  EXPECT_NEAR(darkest, 0.75, 0.012);  // under the ball's centre: 1 - r^2 / h^2

  Mesh no_uvs = m;
  no_uvs.uvs.clear();
  EXPECT_THROW(bake_light_map(no_uvs, 8, 8), std::invalid_argument);
}

}  // namespace
}  // namespace arlight::render

namespace arlight::render {
namespace {

// A plate (y = 0, x in [-1.2, 0], normal +y) beside a wall (x = 0, 2 high, facing the plate),
// world frame = scene frame, y up.
Mesh plate_and_wall() {
  Mesh m;
  const auto quad = [&](glm::vec3 origin, glm::vec3 u, glm::vec3 v, int n) {
    const glm::vec3 normal = glm::normalize(glm::cross(v, u));
    const auto base = std::uint32_t(m.positions.size());
    for (int j = 0; j <= n; ++j)
      for (int i = 0; i <= n; ++i) {
        m.positions.push_back(origin + u * (float(i) / n) + v * (float(j) / n));
        m.normals.push_back(normal);
      }
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) {
        const std::uint32_t a = base + std::uint32_t(j * (n + 1) + i), b = a + 1,
                            c = a + std::uint32_t(n + 1), d = c + 1;
        m.indices.insert(m.indices.end(), {a, c, b, b, c, d});
      }
  };
  quad({-1.2f, 0.0f, -0.6f}, {1.2f, 0.0f, 0.0f}, {0.0f, 0.0f, 1.2f}, 24);  // normal +y
  quad({0.0f, 0.0f, -3.0f}, {0.0f, 0.0f, 6.0f}, {0.0f, 2.0f, 0.0f}, 4);    // normal -x
  compute_bounds(m);
  return m;
}

// The room L(w) = (1 + w.s)^2: bands 0-2 exactly, brightest towards s.
ShCoeffs lobe_room(glm::dvec3 s) {
  const EnvLayout layout = EnvLayout::for_size(Projection::LatLong, 256);
  EnvMap env(layout);
  for (int y = 0; y < layout.height(); ++y)
    for (int x = 0; x < layout.width(); ++x) {
      const double c = 1.0 + glm::dot(layout.texel_dir(x, y), s);
      env.image.set(x, y, glm::vec3(float(c * c)));
    }
  return sh_project(env, 3);
}

// What Sloan et al.'s transfer gives and ambient occlusion cannot: the plate beside the wall is
// dark when the room's light comes from over the wall and bright when it comes from the open
// side. Under a room of bands 0-2 the transfer dotted with its SH is the occluded light exactly
// (up to the bake's 1,024 directions): the plate's pixels against Embree's irradiance over 16k
// directions, for both sides; the bent normal and occlusion alone miss by far on the dark side.
TEST(BakedTransfer, TheShadowFollowsWhereTheLightComesFrom) {
  context();
  constexpr int kW = 160, kH = 120;
  Mesh baked = plate_and_wall();
  bake_occlusion(baked, 1024);
  ASSERT_EQ(baked.transfer.size(), baked.vertex_count() * kTransferCoefficients);
  Mesh ao_only = baked;
  ao_only.transfer.clear();
  const Occluder occluder(baked.positions, baked.indices);
  constexpr int kRays = 16384;
  std::vector<glm::dvec3> dirs;
  for (int i = 0; i < kRays; ++i) {
    const double y = 1.0 - (i + 0.5) * 2.0 / kRays, r = std::sqrt(1.0 - y * y);
    const double phi = i * std::numbers::pi * (3.0 - std::sqrt(5.0));
    dirs.push_back({r * std::cos(phi), y, r * std::sin(phi)});
  }
  const CameraIntrinsics k = CameraIntrinsics::from_fov(kW, kH, 50.0);
  const glm::dmat4 camera_from_scene =
      glm::lookAt(glm::dvec3(-0.6, 2.2, 0.0), glm::dvec3(-0.6, 0.0, 0.0), glm::dvec3(1, 0, 0));
  const glm::dmat4 view_proj =
      glm::dmat4(projection_from_intrinsics(k, kW, kH, 0.01f, 100.0f)) * camera_from_scene;
  const glm::dmat4 inv = glm::inverse(view_proj);
  Material m;
  m.kd = glm::vec3(1.0f);
  m.double_sided = true;

  double mean[2][3] = {};  // [side][truth, transfer, occlusion only]
  for (int side = 0; side < 2; ++side) {
    const glm::dvec3 s = glm::normalize(glm::dvec3(side == 0 ? 1.0 : -1.0, 0.25, 0.0));
    const ShCoeffs room = lobe_room(s);
    Renderer r(kW, kH);
    r.set_sh(room);
    r.set_camera(k, camera_from_scene);
    const auto draw = [&](const Mesh& mesh) {
      const GpuMesh gpu(mesh);
      r.begin_frame();
      r.draw(gpu, m, glm::mat4(1.0f));
      return r.read_hdr();
    };
    const HdrReadback with_transfer = draw(baked), with_ao = draw(ao_only);
    double err = 0;
    int n = 0;
    for (int y = 2; y < kH; y += 4)
      for (int x = 2; x < kW; x += 4) {
        // The plate's point under the pixel (row 0 at the top: NDC y grows with the row).
        const glm::dvec2 ndc((x + 0.5) / kW * 2 - 1, (y + 0.5) / kH * 2 - 1);
        const glm::dvec4 a = inv * glm::dvec4(ndc, -1, 1), b = inv * glm::dvec4(ndc, 1, 1);
        const glm::dvec3 p0 = glm::dvec3(a) / a.w, p1 = glm::dvec3(b) / b.w;
        const glm::dvec3 p = p0 + (p1 - p0) * (p0.y / (p0.y - p1.y));
        if (p.x < -1.1 || p.x > -0.1 || std::abs(p.z) > 0.5) continue;
        ASSERT_TRUE(with_transfer.mask[std::size_t(y) * kW + x]) << x << "," << y;
        std::vector<std::uint8_t> hit(dirs.size());
        occluder.occluded(p + glm::dvec3(0, 1e-4, 0), dirs, hit);
        double truth = 0;
        for (std::size_t i = 0; i < dirs.size(); ++i)
          if (!hit[i] && dirs[i].y > 0)
            truth += std::max(sh_evaluate(room, dirs[i]).g, 0.0) * dirs[i].y;
        truth *= 4.0 / kRays;  // dw / pi = 4 pi / N / pi
        const double got = with_transfer.radiance.at(x, y).g, ao = with_ao.radiance.at(x, y).g;
        mean[side][0] += truth, mean[side][1] += got, mean[side][2] += ao;
        err += std::abs(got - truth) / truth;
        ++n;
      }
    ASSERT_GT(n, 200);
    for (double& v : mean[side]) v /= n;
    std::printf(
        "[transfer] light from %s: plate %.3f ray-traced, %.3f transfer (mean |error| %.1f %%), "
        "%.3f occlusion only\n",
        side == 0 ? "over the wall" : "the open side", mean[side][0], mean[side][1], 100 * err / n,
        mean[side][2]);
    EXPECT_LT(err / n, 0.04);
  }
  // Over the wall the plate gets far less than from the open side, and the transfer says so.
  const double truth_ratio = mean[0][0] / mean[1][0], transfer_ratio = mean[0][1] / mean[1][1],
               ao_ratio = mean[0][2] / mean[1][2];
  std::printf(
      "[transfer] dark / bright side: ray-traced %.3f, transfer %.3f, occlusion only %.3f\n",
      truth_ratio, transfer_ratio, ao_ratio);
  EXPECT_LT(truth_ratio, 0.6);
  EXPECT_NEAR(transfer_ratio, truth_ratio, 0.03);
  // The occlusion alone (bent normal, uniform share) leaves the plate >= 10 % too bright when the
  // light is over the wall, and its contrast between the sides >= 10 % too weak.
  EXPECT_GT(mean[0][2] / mean[0][0] - 1.0, 0.1);
  EXPECT_GT(ao_ratio / truth_ratio - 1.0, 0.1);
}

}  // namespace
}  // namespace arlight::render
