// The GL-free placement both clients share (client/app/include/arlight/app/placement.hpp): how long
// a tracked pose holds, how it is carried on to a later frame, where the preview stands, and
// the soft shadow's budget.
#include <gtest/gtest.h>

#include <glm/gtc/quaternion.hpp>

#include "arlight/app/placement.hpp"

using namespace arlight;
using namespace arlight::client_app;

namespace {
const Pose kCamera{glm::angleAxis(0.3, glm::dvec3(0, 1, 0)), {0.1, -0.4, 0.5}};
}

TEST(MarkerPlacement, APoseHoldsForItsTimeThenIsGone) {
  MarkerPlacement p({.hold_s = 0.2});
  EXPECT_FALSE(p.camera_in_marker(0.0));
  p.tracked(1.0, kCamera);
  ASSERT_TRUE(p.camera_in_marker(1.2));
  EXPECT_EQ(p.camera_in_marker(1.2)->position, kCamera.position);  // no velocity: not moved
  EXPECT_FALSE(p.camera_in_marker(1.21));
  p.forget();
  EXPECT_FALSE(p.camera_in_marker(1.0));
}

TEST(MarkerPlacement, ALaterFrameIsMovedOnByTheVelocityAndTurnedByTheSensor) {
  MarkerPlacement p({.extrapolate_s = 0.5});
  const glm::dquat at_track = glm::angleAxis(0.2, glm::dvec3(1, 0, 0));
  p.tracked(2.0, kCamera, {1.0, 0.0, -2.0}, at_track);
  // 0.25 s later the camera has moved 0.25 x velocity and turned 0.1 rad about world +Y.
  const glm::dquat turn = glm::angleAxis(0.1, glm::dvec3(0, 1, 0));
  const auto later = p.camera_in_marker(2.25, turn * at_track);
  ASSERT_TRUE(later);
  EXPECT_NEAR(glm::length(later->position - (kCamera.position + glm::dvec3(0.25, 0, -0.5))), 0.0,
              1e-12);
  const glm::dquat expected = kCamera.orientation * glm::conjugate(at_track) * turn * at_track;
  EXPECT_NEAR(std::abs(glm::dot(later->orientation, glm::normalize(expected))), 1.0, 1e-12);
  // Past the extrapolation limit it stays where it was tracked (held: the page's hold is forever).
  EXPECT_EQ(p.camera_in_marker(3.0, at_track)->position, kCamera.position);
  // The tracked frame alone says where the marker is: the camera's orientation times its pose's.
  EXPECT_NEAR(std::abs(glm::dot(*p.world_from_marker_of_track(),
                                at_track * glm::conjugate(kCamera.orientation))),
              1.0, 1e-12);
}

TEST(PreviewPlacement, TheObjectStandsUprightAheadOfTheCameraBelowTheViewsCentre) {
  const glm::dquat world_from_camera = glm::angleAxis(1.0, glm::normalize(glm::dvec3(1, 2, 0.5)));
  const double height = 0.3;
  const auto [camera_in_scene, world_from_scene] = preview_placement(world_from_camera, height);
  // The scene's +Z is the world's up.
  EXPECT_NEAR(glm::length(world_from_scene * glm::dvec3(0, 0, 1) - glm::dvec3(0, 1, 0)), 0.0,
              1e-12);
  // The scene's origin seen from the camera: 4 heights ahead, half a height down.
  const Pose scene_in_camera = inverse(camera_in_scene);
  EXPECT_NEAR(glm::length(scene_in_camera.position - glm::dvec3(0, -0.15, -1.2)), 0.0, 1e-9);
  // And the camera's orientation in the world is what it was.
  EXPECT_NEAR(std::abs(glm::dot(world_from_scene * camera_in_scene.orientation, world_from_camera)),
              1.0, 1e-12);
}

TEST(ShadowBudget, ItsLightsFollowTheFramesThatDrewAShadow) {
  client::Lighting lighting;
  lighting.dominant_direction = {0, 1, 0};
  lighting.dominant_colour = {2, 2, 2};
  ShadowBudget fixed(12, 0);
  const render::ShadowSettings s = fixed.settings(true, lighting);
  EXPECT_TRUE(s.enabled);
  EXPECT_EQ(s.lights, 12);
  EXPECT_EQ(s.light_colour, glm::vec3(2.0f));
  fixed.frame_took(1000.0, true);
  EXPECT_EQ(fixed.lights(), 12);  // no target: always the maximum

  ShadowBudget held(16, 30);
  const int start = held.lights();
  EXPECT_EQ(start, 4);
  for (int i = 0; i < 10; ++i) held.frame_took(100.0, false);  // no shadow drawn: not counted
  EXPECT_EQ(held.lights(), start);
  for (int i = 0; i < 3; ++i) held.frame_took(100.0, true);  // 3x over 33 ms: fewer
  EXPECT_LT(held.lights(), start);
  EXPECT_THROW(ShadowBudget(0, 30), std::invalid_argument);
  EXPECT_THROW(ShadowBudget(4, -1), std::invalid_argument);
}
