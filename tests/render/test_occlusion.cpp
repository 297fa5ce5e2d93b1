// The mesh's occlusion of itself, baked (tutorial §6.1; render::bake_occlusion) and shaded: the
// diffuse light comes along the bent normal, scaled by the ambient occlusion.
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
