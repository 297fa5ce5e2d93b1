#include "arlight/app/placement.hpp"

#include <algorithm>
#include <glm/gtc/quaternion.hpp>
#include <stdexcept>
#include <string>

namespace arlight::client_app {

namespace {
constexpr double kPreviewDistance = 4.0, kPreviewDrop = 0.5;  // object heights
}  // namespace

void MarkerPlacement::tracked(double t, const Pose& camera_in_marker, const glm::dvec3& velocity,
                              std::optional<glm::dquat> world_from_camera) {
  track_ = Track{t, camera_in_marker, velocity, world_from_camera};
}

std::optional<Pose> MarkerPlacement::camera_in_marker(
    double t, std::optional<glm::dquat> world_from_camera) const {
  if (!track_ || !(t - track_->t <= options_.hold_s)) return std::nullopt;
  Pose p = track_->camera_in_marker;
  if (world_from_camera && track_->world_from_camera) {
    const glm::dquat since = glm::conjugate(*track_->world_from_camera) * *world_from_camera;
    p.orientation = glm::normalize(p.orientation * since);
  }
  const double ahead = t - track_->t;
  if (ahead > 0 && ahead <= options_.extrapolate_s) p.position += ahead * track_->velocity;
  return p;
}

std::optional<glm::dquat> MarkerPlacement::world_from_marker_of_track() const {
  if (!track_ || !track_->world_from_camera) return std::nullopt;
  return *track_->world_from_camera * glm::conjugate(track_->camera_in_marker.orientation);
}

std::pair<Pose, glm::dquat> preview_placement(const glm::dquat& world_from_camera,
                                              double object_height) {
  const glm::dmat3 axes(glm::dvec3(1, 0, 0), glm::dvec3(0, 0, -1), glm::dvec3(0, 1, 0));
  const glm::dquat world_from_scene = glm::quat_cast(axes);
  const glm::dvec3 origin =
      world_from_camera * (object_height * glm::dvec3(0, -kPreviewDrop, -kPreviewDistance));
  const Pose camera_in_scene =
      compose(inverse(Pose{world_from_scene, origin}), Pose{world_from_camera, glm::dvec3(0.0)});
  return {camera_in_scene, world_from_scene};
}

ShadowBudget::ShadowBudget(int max_lights, double target_fps)
    : max_lights_(max_lights), target_fps_(target_fps) {
  if (max_lights < 1 || max_lights > render::kMaxShadowLights || !(target_fps >= 0))
    throw std::invalid_argument("ShadowBudget: " + std::to_string(max_lights) + " lights at " +
                                std::to_string(target_fps) + " fps");
  // Starting at 4 (or fewer) the count settles from below: the first frames stay fast.
  if (target_fps > 0) control_.emplace(1000.0 / target_fps, max_lights, std::min(4, max_lights));
}

render::ShadowSettings ShadowBudget::settings(bool enabled,
                                              const client::Lighting& lighting) const {
  render::ShadowSettings shadow;
  shadow.enabled = enabled;
  shadow.light_direction = lighting.dominant_direction;
  shadow.light_colour = lighting.dominant_colour;
  shadow.lights = lights();
  return shadow;
}

void ShadowBudget::frame_took(double ms, bool shadow_drawn) {
  // Tutorial §6.4: the next frame's lights from this one's time; a frame that drew no shadow
  // says nothing about what the shadow costs.
  if (control_ && shadow_drawn) control_->update(ms);
}

}  // namespace arlight::client_app
