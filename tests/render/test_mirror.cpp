// A chrome sphere (kd = 0, ks = 1) in an environment with one bright texel: the highlight lands
// where the mirror-reflection geometry says, for every projection, with the camera tilted and
// with a non-identity world_from_scene. This pins the GLSL direction -> texel lookup, the
// reflection vector and the scene -> world rotation together.
#include <glm/gtc/matrix_transform.hpp>

#include "render_fixtures.hpp"

namespace arlight::render {
namespace {

using namespace testing;

constexpr int W = 200, H = 200;
constexpr double kRadius = 1.0;

// The point of the sphere (camera coordinates) that mirrors the direction `d` (camera
// coordinates, pointing away from the sphere) into the camera at the origin: its normal bisects
// the reversed view ray and d. Fixed-point iteration on n = normalize(d - v_in).
glm::dvec3 mirror_point(glm::dvec3 centre, double radius, glm::dvec3 d) {
  glm::dvec3 n = glm::normalize(d - glm::normalize(centre));
  for (int i = 0; i < 200; ++i) {
    const glm::dvec3 v_in = glm::normalize(centre + radius * n);
    n = glm::normalize(d - v_in);
  }
  return centre + radius * n;
}

struct Case {
  Projection projection;
  bool rotated_world;
};

class MirrorSphere : public ::testing::TestWithParam<Case> {};

TEST_P(MirrorSphere, HighlightLandsWhereTheReflectionMathSays) {
  GlContext& ctx = context();
  (void)ctx;
  const Case c = GetParam();
  Renderer r(W, H);
  const CameraIntrinsics k = CameraIntrinsics::from_fov(W, H, 40.0);
  const PinholeCamera cam(k);
  // Camera 4 units from the sphere, tilted 20 degrees down (looking at the marker from above).
  const glm::dmat4 camera_from_scene = glm::translate(glm::dmat4(1.0), glm::dvec3(0.1, -0.05, -4.0)) *
                                       glm::rotate(glm::dmat4(1.0), glm::radians(20.0), glm::dvec3(1, 0, 0));
  r.set_camera(k, camera_from_scene);
  const glm::dquat world_from_scene =
      c.rotated_world ? glm::angleAxis(glm::radians(75.0), glm::normalize(glm::dvec3(0.3, 1.0, -0.2)))
                      : glm::dquat(1, 0, 0, 0);
  r.set_world_from_scene(world_from_scene);
  const glm::dmat3 cam_from_scene_rot(camera_from_scene);
  const glm::dvec3 centre_cam(camera_from_scene * glm::dvec4(0, 0, 0, 1));

  GpuMesh sphere(make_sphere(float(kRadius), 96, 192));
  Material chrome;
  chrome.kd = glm::vec3(0.0f);
  chrome.ks = glm::vec3(1.0f);
  chrome.shininess = 5000.0f;

  const int n = c.projection == Projection::Cube ? 16 : c.projection == Projection::LatLong ? 32 : 64;
  const EnvLayout layout = EnvLayout::for_size(c.projection, n);
  for (glm::dvec3 d_cam : {glm::dvec3(0.3, 0.4, 0.87), glm::dvec3(-0.7, 0.3, 0.4), glm::dvec3(0.2, -0.6, 0.5)}) {
    // The bright texel nearest the wanted direction; the expectation uses its exact centre.
    const glm::dvec3 d_world0 = world_from_scene * (glm::transpose(cam_from_scene_rot) * glm::normalize(d_cam));
    const glm::ivec2 t = layout.dir_to_texel(d_world0);
    const glm::dvec3 d_world = layout.texel_dir(t.x, t.y);
    const glm::dvec3 d = cam_from_scene_rot * (glm::inverse(world_from_scene) * d_world);
    EnvMap env(layout);
    env.image.set(t.x, t.y, glm::vec3(1000.0f));
    r.set_maps({1.0, 1000.0}, {env, env});

    r.begin_frame();
    r.draw(sphere, chrome, glm::mat4(1.0f));
    const HdrReadback hdr = r.read_hdr();
    const glm::dvec2 want = *cam.project(mirror_point(centre_cam, kRadius, d));

    float peak = 0;
    glm::ivec2 argmax(-1);
    for (int y = 0; y < H; ++y)
      for (int x = 0; x < W; ++x)
        if (hdr.radiance.at(x, y).g > peak) peak = hdr.radiance.at(x, y).g, argmax = {x, y};
    ASSERT_GT(peak, 10.0f) << "no highlight for " << d.x << "," << d.y << "," << d.z;
    // Centroid of the spot (the bilinear tent of the texel, above a quarter of the peak).
    glm::dvec2 sum(0.0);
    double wsum = 0;
    for (int y = 0; y < H; ++y)
      for (int x = 0; x < W; ++x) {
        const double v = hdr.radiance.at(x, y).g;
        if (v < 0.25 * peak || glm::length(glm::dvec2(x, y) - glm::dvec2(argmax)) > 15) continue;
        sum += v * glm::dvec2(x, y), wsum += v;
      }
    const glm::dvec2 centroid = sum / wsum;
    EXPECT_LT(glm::length(centroid - want), 1.0)
        << projection_name(c.projection) << " d_cam " << d.x << "," << d.y << "," << d.z
        << ": centroid " << centroid.x << "," << centroid.y << " want " << want.x << "," << want.y;
    EXPECT_LT(glm::length(glm::dvec2(argmax) - want), 1.5)
        << "argmax " << argmax.x << "," << argmax.y << " want " << want.x << "," << want.y;
  }
}

INSTANTIATE_TEST_SUITE_P(Projections, MirrorSphere,
                         ::testing::Values(Case{Projection::AngleMap, false}, Case{Projection::AngleMap, true},
                                           Case{Projection::LatLong, false}, Case{Projection::LatLong, true},
                                           Case{Projection::Cube, false}, Case{Projection::Cube, true}),
                         [](const auto& info) {
                           return std::string(projection_name(info.param.projection)) +
                                  (info.param.rotated_world ? "_rotated_world" : "");
                         });

}  // namespace
}  // namespace arlight::render
