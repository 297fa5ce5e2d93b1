// The ray-traced reference (sim/reference): a sphere standing on the floor in a uniform room,
// where the object's radiance and its shadow have closed forms.
#include <gtest/gtest.h>

#include <cmath>
#include <glm/gtc/quaternion.hpp>
#include <opencv2/core.hpp>

#include "arlight/common/error.hpp"
#include "arlight/reference/reference.hpp"

namespace {

using namespace arlight;
using reference::PlacedObject;
using reference::ReferenceScene;

// The marker on the floor 1.2 m below the world's origin: marker x -> world +X, y -> -Z,
// z (out of the marker) -> +Y.
Pose marker_on_floor() {
  Pose p;
  p.orientation = glm::angleAxis(-glm::half_pi<double>(), glm::dvec3(1, 0, 0));
  p.position = {0.0, -1.2, -0.8};
  return p;
}

EnvMap uniform_room(float radiance) {
  return EnvMap(EnvLayout(Projection::LatLong, 128, 64), Image(128, 64, glm::vec3(radiance)));
}

// A sphere 0.3 m across (radius 0.15) standing on the marker.
PlacedObject sphere(const render::Material& material) {
  return {render::make_sphere(0.5f, 64, 128), material, 0.3, marker_on_floor()};
}

TEST(Reference, ASpheresTopInAUniformRoomReflectsAllOfIt) {
  render::Material m;
  m.kd = glm::vec3(0.8f), m.ks = glm::vec3(0.2f), m.shininess = 80;
  const ReferenceScene scene(sphere(m), uniform_room(2.0f), {});
  // From straight above: nothing hides the top's hemisphere, so Ld = L and Ls = L (the mirror
  // lobe points up): 0.8 x 2 + 0.2 x 2.
  const Pose marker = marker_on_floor();
  const auto top = scene.object_radiance(marker.position + glm::dvec3(0, 2, 0), {0, -1, 0});
  ASSERT_TRUE(top);
  EXPECT_NEAR(top->x, 2.0f, 0.02f);
  // Its side too: the room is all around (the floor is part of the probe, not geometry) and a
  // convex body hides nothing from itself.
  const auto side = scene.object_radiance(marker.position + glm::dvec3(2, 0.15, 0), {-1, 0, 0});
  ASSERT_TRUE(side);
  EXPECT_NEAR(side->x, 2.0f, 0.03f);
  EXPECT_FALSE(scene.object_radiance(marker.position + glm::dvec3(2, 0.15, 0), {1, 0, 0}));
}

// glTF metallic-roughness (issue 34 §3): the full BRDF with Kulla & Conty's multiple scattering
// passes the white furnace — a white metal reflects the whole room at every roughness, narrow
// lobes (importance-sampled) and wide ones (summed) alike — and a black dielectric shows only
// its Fresnel reflection (F0 = 0.04 head-on, rising at grazing views).
TEST(Reference, MetallicRoughnessPassesTheWhiteFurnace) {
  const Pose marker = marker_on_floor();
  for (float roughness : {0.05f, 0.3f, 0.8f}) {
    render::Material m;
    m.pbr = render::MetallicRoughness{};
    m.pbr->base_colour = glm::vec4(1.0f);
    m.pbr->metallic = 1.0f;
    m.pbr->roughness = roughness;
    const ReferenceScene scene(sphere(m), uniform_room(2.0f), {});
    const auto top = scene.object_radiance(marker.position + glm::dvec3(0, 2, 0), {0, -1, 0});
    ASSERT_TRUE(top);
    EXPECT_NEAR(top->x, 2.0f, 0.03f) << "roughness " << roughness;
    const auto side = scene.object_radiance(marker.position + glm::dvec3(2, 0.15, 0.05), {-1, 0, 0});
    ASSERT_TRUE(side);
    EXPECT_NEAR(side->x, 2.0f, 0.05f) << "roughness " << roughness;
  }
  render::Material black;
  black.pbr = render::MetallicRoughness{};
  black.pbr->base_colour = glm::vec4(0.0f, 0.0f, 0.0f, 1.0f);
  black.pbr->metallic = 0.0f;
  black.pbr->roughness = 0.3f;
  const ReferenceScene scene(sphere(black), uniform_room(2.0f), {});
  const auto top = scene.object_radiance(marker.position + glm::dvec3(0, 2, 0), {0, -1, 0});
  ASSERT_TRUE(top);
  EXPECT_NEAR(top->x, 2.0f * 0.045f, 0.02f);  // ~F0 (its albedo a + 0.04 (b - a) head-on)
}

TEST(Reference, TheShadowOfASphereInAUniformRoomIsItsProjectedSolidAngle) {
  // A sphere of radius r touching the floor, seen from a floor point at horizontal distance d:
  // it hides the cosine-weighted share cos(theta) r^2 / D^2 = r^3 / D^3 of a uniform sky
  // (D^2 = d^2 + r^2), so the ratio is 1 - r^3 / (d^2 + r^2)^1.5.
  render::Material m;
  const ReferenceScene scene(sphere(m), uniform_room(1.0f), {});
  const Pose marker = marker_on_floor();
  const double r = 0.15;
  for (const double d : {0.6 * r, 1.0 * r, 2.0 * r, 3.0 * r}) {
    const double expected = 1 - std::pow(r, 3) / std::pow(d * d + r * r, 1.5);
    for (const glm::dvec3 dir : {glm::dvec3(1, 0, 0), glm::normalize(glm::dvec3(-1, 0, 1))}) {
      const double ratio = scene.shadow_ratio(marker.position + d * dir);
      EXPECT_NEAR(ratio, expected, 0.015) << "d = " << d / r << " r";
    }
  }
  EXPECT_EQ(scene.shadow_ratio(marker.position + glm::dvec3(20 * r, 0, 0)), 1.0);  // off the grid
}

TEST(Reference, AViewChangesOnlyTheObjectAndItsShadow) {
  render::Material m;
  m.kd = glm::vec3(0.5f), m.ks = glm::vec3(0.0f);
  const ReferenceScene scene(sphere(m), uniform_room(1.0f), {});
  const CameraIntrinsics k = CameraIntrinsics::from_fov(160, 120, 60.0);
  // A camera 1 m above and 0.6 m back from the marker, looking at it (down 59 degrees).
  Pose camera;
  const Pose marker = marker_on_floor();
  camera.position = marker.position + glm::dvec3(0, 1.0, 0.6);
  camera.orientation = glm::angleAxis(-std::atan2(1.0, 0.6), glm::dvec3(1, 0, 0));
  const cv::Mat frame(120, 160, CV_8UC3, cv::Scalar(90, 100, 110));
  const double exposure = 0.25;
  const reference::ReferenceView v =
      scene.render(k, camera, frame, exposure, CameraResponse::srgb());
  const int object = cv::countNonZero(v.object_mask), shadow = cv::countNonZero(v.shadow_mask);
  EXPECT_GT(object, 300);
  EXPECT_GT(shadow, 100);
  EXPECT_EQ(cv::countNonZero(v.object_mask & v.shadow_mask), 0);
  // The image centre looks at the sphere: a convex body in a uniform room has radiance kd L.
  const cv::Vec3b centre = v.composite.at<cv::Vec3b>(60, 80);
  const int expected =
      int(std::lround(255 * CameraResponse::srgb().encode(float(0.5 * exposure), 0)));
  ASSERT_EQ(v.object_mask.at<std::uint8_t>(60, 80), 255);
  EXPECT_NEAR(centre[0], expected, 1);
  // Outside the object only the darkened floor changed, and all of the shadow mask did.
  cv::Mat diff, changed_sum, ratio_sum;
  cv::absdiff(v.composite, frame, diff);
  cv::transform(diff, changed_sum, cv::Matx13f(1, 1, 1));
  cv::transform(v.shadow_ratio, ratio_sum, cv::Matx13f(1, 1, 1));
  const cv::Mat changed = changed_sum > 0;
  EXPECT_EQ(cv::countNonZero(changed & ~v.object_mask & (ratio_sum >= 2.9999f)), 0);
  EXPECT_EQ(cv::countNonZero(changed & v.shadow_mask), shadow);
}

TEST(Reference, RefusesWhatItCannotTrace) {
  render::Material glass = render::glass();
  EXPECT_THROW(ReferenceScene(sphere(glass), uniform_room(1.0f), {}), InputError);
  render::Material textured;
  textured.pbr = render::MetallicRoughness{};
  textured.pbr->occlusion = std::make_shared<const render::TextureImage>();
  EXPECT_THROW(ReferenceScene(sphere(textured), uniform_room(1.0f), {}), InputError);
  PlacedObject empty = sphere(render::Material{});
  empty.mesh = render::Mesh{};
  EXPECT_THROW(ReferenceScene(empty, uniform_room(1.0f), {}), InputError);
  const ReferenceScene scene(sphere(render::Material{}), uniform_room(1.0f), {});
  const CameraIntrinsics k = CameraIntrinsics::from_fov(160, 120, 60.0);
  EXPECT_THROW(scene.render(k, Pose{}, cv::Mat(100, 100, CV_8UC3), 0.1, CameraResponse::srgb()),
               InputError);
}

}  // namespace
