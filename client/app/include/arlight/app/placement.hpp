// Where the object is drawn in a frame and what its soft shadow may cost: the GL-free part of
// the per-frame pipeline both clients run (FramePipeline natively, the page through
// WebAssembly). No I/O, no GL: tested on its own (tests/app/test_placement.cpp).
#pragma once

#include <limits>
#include <optional>

#include "arlight/common/pose.hpp"
#include "arlight/net/lighting_state.hpp"
#include "arlight/render/render.hpp"

namespace arlight::client_app {

// The newest tracking result, held for a while and carried on to the frame being drawn.
class MarkerPlacement {
 public:
  struct Options {
    // How long after its frame a tracked pose still places the object (a marker lost for a
    // moment: motion blur, a hand); infinity: until the marker is seen again.
    double hold_s = std::numeric_limits<double>::infinity();
    // A later frame's camera is moved on by the pose filter's velocity, at most this far ahead
    // of the tracked frame (0: not).
    double extrapolate_s = 0;
  };
  explicit MarkerPlacement(Options options) : options_(options) {}

  // A tracking result for the frame taken at t: the camera in the marker frame (smoothed), its
  // velocity there (m/s), and the camera's orientation when the frame was taken (camera ->
  // world; unknown for a webcam before its visual gyroscope has one).
  void tracked(double t, const Pose& camera_in_marker, const glm::dvec3& velocity = glm::dvec3(0),
               std::optional<glm::dquat> world_from_camera = std::nullopt);
  void forget() { track_.reset(); }

  // The camera in the marker frame for a frame taken at t, or nothing when no pose holds. With
  // the frame's orientation (and the tracked frame's), the pose turns by the rotation the
  // orientation sensor measured between the two: the page's tracker trails the shown frame.
  std::optional<Pose> camera_in_marker(double t,
                                       std::optional<glm::dquat> world_from_camera = {}) const;
  bool has_track() const { return track_.has_value(); }
  // The marker's rotation into the world as the tracked frame alone says it (its orientation
  // sensor and its pose), when that frame's orientation is known.
  std::optional<glm::dquat> world_from_marker_of_track() const;

 private:
  struct Track {
    double t;
    Pose camera_in_marker;
    glm::dvec3 velocity;
    std::optional<glm::dquat> world_from_camera;
  };
  Options options_;
  std::optional<Track> track_;
};

// Before any marker (the page's preview): the object floats 4 of its heights ahead of the
// camera and half a height below the view's centre, upright in the world, so the room's light
// on it shows from the first frame wherever the phone points. The scene frame has +Z up (world
// +Y), +X world +X, +Y world -Z (right-handed, as a marker's). Returns the camera in that frame
// and the scene's rotation into the world.
std::pair<Pose, glm::dquat> preview_placement(const glm::dquat& world_from_camera,
                                              double object_height);

// The soft shadow (tutorial §6, §6.4): at most max_lights hard shadows blended, as many as hold
// target_fps for the frames that draw one (render::LightCountControl; 0: always max_lights).
class ShadowBudget {
 public:
  // Callers check their own flags' ranges; std::invalid_argument for max_lights outside
  // [1, kMaxShadowLights] or a target_fps < 0.
  ShadowBudget(int max_lights, double target_fps);

  // The renderer's shadow for a frame: on or off, the dominant light as arlightd sends it
  // (world frame), and the hard shadows the budget allows now.
  render::ShadowSettings settings(bool enabled, const client::Lighting& lighting) const;
  // A frame took `ms` of the client's own work; it counts when it drew the shadow.
  void frame_took(double ms, bool shadow_drawn);

  int lights() const { return control_ ? control_->lights() : max_lights_; }
  int max_lights() const { return max_lights_; }
  double target_fps() const { return target_fps_; }

 private:
  int max_lights_;
  double target_fps_;
  std::optional<render::LightCountControl> control_;  // with target_fps > 0
};

}  // namespace arlight::client_app
