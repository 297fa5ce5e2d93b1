// Camera trajectories of a simulated capture: where the phone is and where it looks at any
// time. The sweep follows the capture procedure of thesis ch. 3 (Kán's technique: the user
// turns the device around until the whole sphere is covered), as a smooth path of yaw sweeps
// at several pitch bands plus views straight up and down.
#pragma once

#include <cstdint>
#include <functional>
#include <glm/gtc/quaternion.hpp>
#include <glm/vec3.hpp>
#include <string_view>
#include <vector>

#include "arlight/truth/truth.hpp"

namespace arlight::sim {

using recording::Pose;

// PolesFirstSweep: the same sweep after a look straight up and straight down (ceiling and
// floor, sky and ground first): the order a capture guide would ask for, so that the estimate
// of what is not seen yet (issue 16 §1) has every elevation early.
// TopDownSweep: straight up, then the bands from the top down, then straight down: the
// ceiling or sky (where a room's light mostly comes from) first, the floor last; the order the
// phone page's guide asks for.
enum class TrajectoryKind { Sweep, Orbit, Handheld, PolesFirstSweep, TopDownSweep };

// The kind a command line names: sweep, poles-first, top-down, orbit or handheld. InputError
// "--trajectory '<name>': use ..." for anything else.
TrajectoryKind trajectory_from_name(std::string_view name);

struct TrajectoryParams {
  TrajectoryKind kind = TrajectoryKind::Sweep;
  double duration = 10;  // seconds from the first frame to the last
  double hfov_deg = 60;  // the camera's horizontal and vertical fields of view
  double vfov_deg = 46.8;
  glm::dvec3 target{0.0, -1.2, -0.8};  // the point an orbit circles (the marker's centre)
  std::uint64_t seed = 0;              // hand jitter and orbit wander
};

// The vertical field of view (degrees) of a pinhole camera of this horizontal one and size.
double vertical_fov_deg(double hfov_deg, int width, int height);

// Camera -> world rotation of a camera turned by yaw (about world +Y, positive turns -Z
// towards -X), then pitch (positive looks up), then roll about the view axis; radians.
glm::dquat yaw_pitch_roll(double yaw, double pitch, double roll = 0.0);

// Camera -> world rotation looking from `eye` at `at` with no roll (camera x horizontal).
glm::dquat look_at(const glm::dvec3& eye, const glm::dvec3& at);

class Trajectory {
 public:
  explicit Trajectory(const TrajectoryParams& params);

  const TrajectoryParams& params() const { return p_; }
  // The exact camera pose at time t (seconds, clamped to [0, duration]).
  Pose at(double t) const;
  // The true angular velocity at time t in camera coordinates (rad/s), by central differences.
  glm::dvec3 angular_velocity(double t) const;
  // The sweep's pitch bands in degrees, top to bottom (also the handheld path's).
  const std::vector<double>& bands() const { return bands_; }

 private:
  struct Segment {
    int kind;              // 0 pitch ramp (eased), 1 yaw sweep, 2 U-turn between bands
    double yaw0, pitch0;   // degrees at the start
    double yaw1, pitch1;   // degrees at the end (U-turn: the same yaw, the next band's pitch)
    double sweep_dir;      // U-turn: the yaw direction of the band it leaves
    double start, length;  // time allocation (seconds)
  };
  // Yaw and pitch (degrees) of segment s at its parameter tau in [0, 1].
  static void eval(const Segment& s, double tau, double& yaw, double& pitch);
  void sweep_angles(double t, double& yaw, double& pitch) const;
  void build_sweep();
  void build_handheld();

  TrajectoryParams p_;
  std::vector<double> bands_;
  std::vector<Segment> segments_;
  // Handheld: knots every kTremorKnotSeconds of the angle jitter (yaw, pitch, roll; degrees) and
  // the position random walk (x, y, z; metres), interpolated with Catmull-Rom splines.
  std::vector<double> jitter_[3], walk_[3];
  // Orbit: knots of the look-at point's wander around the target (x, z; metres).
  std::vector<double> wander_[2];
};

// The angular velocity (camera coordinates, rad/s) at time t of a path of orientations (camera ->
// world) defined on [0, duration], by central differences.
glm::dvec3 angular_velocity(const std::function<glm::dquat(double)>& orientation_at, double t,
                            double duration);

// The pitch bands (degrees, top to bottom) a sweep needs to cover the sphere with a camera of
// these fields of view: adjacent bands overlap by >= 20% of the vertical field of view, the top
// and bottom bands overlap the views straight up and down by 25%.
std::vector<double> sweep_bands(double hfov_deg, double vfov_deg);

}  // namespace arlight::sim
