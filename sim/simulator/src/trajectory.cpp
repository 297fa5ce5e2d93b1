#include "arlight/sim/trajectory.hpp"

#include <algorithm>
#include <cmath>
#include <glm/geometric.hpp>
#include <glm/gtc/matrix_transform.hpp>
#include <numbers>
#include <functional>
#include <string>

#include "arlight/common/error.hpp"
#include "noise.hpp"

namespace arlight::sim {

namespace {

constexpr double kDeg = std::numbers::pi / 180.0;
constexpr double kWalkStep = 0.004;         // metres per knot and axis (a few cm over a capture)
constexpr double kWanderKnotSeconds = 1.0;  // orbit: the look-at point drifts slowly
constexpr double kWander = 0.05;            // metres
constexpr double kOrbitRadius = 1.0;        // metres, horizontally around the target
constexpr double kOrbitHeight = 0.5;        // metres above the target, +-0.1 over the orbit

double smoothstep(double x) { return x * x * (3.0 - 2.0 * x); }

// The angle of the rotation between two orientations (radians).
double angle_between(const glm::dquat& a, const glm::dquat& b) {
  const double d = std::abs(glm::dot(a, b));
  return 2.0 * std::acos(std::min(1.0, d));
}

}  // namespace

TrajectoryKind trajectory_from_name(std::string_view name) {
  if (name == "sweep") return TrajectoryKind::Sweep;
  if (name == "poles-first") return TrajectoryKind::PolesFirstSweep;
  if (name == "top-down") return TrajectoryKind::TopDownSweep;
  if (name == "orbit") return TrajectoryKind::Orbit;
  if (name == "handheld") return TrajectoryKind::Handheld;
  throw InputError("--trajectory '" + std::string(name) +
                   "': use sweep, poles-first, top-down, orbit or handheld");
}

double vertical_fov_deg(double hfov_deg, int width, int height) {
  return 2.0 * std::atan(std::tan(0.5 * hfov_deg * kDeg) * height / width) / kDeg;
}

glm::dquat yaw_pitch_roll(double yaw, double pitch, double roll) {
  return glm::angleAxis(yaw, glm::dvec3(0, 1, 0)) * glm::angleAxis(pitch, glm::dvec3(1, 0, 0)) *
         glm::angleAxis(roll, glm::dvec3(0, 0, 1));
}

glm::dquat look_at(const glm::dvec3& eye, const glm::dvec3& at) {
  const glm::dvec3 f = glm::normalize(at - eye);
  glm::dvec3 right = glm::cross(f, glm::dvec3(0, 1, 0));
  right = glm::length(right) < 1e-9 ? glm::dvec3(1, 0, 0) : glm::normalize(right);
  const glm::dvec3 up = glm::cross(right, f);
  // Columns: where the camera's x, y and z axes point in the world (it looks down -z).
  return glm::normalize(glm::quat_cast(glm::dmat3(right, up, -f)));
}

std::vector<double> sweep_bands(double hfov_deg, double vfov_deg) {
  // A view straight up covers the cap within min(hfov, vfov)/2 of the zenith (its inscribed
  // circle). The top band's upper edge overlaps that cap by a quarter of the vertical fov;
  // bands in between are spaced by at most 0.8 vfov, i.e. overlap by >= 20%.
  const double cap = 0.5 * std::min(hfov_deg, vfov_deg);
  const double top = std::max(0.0, 90.0 - cap - 0.25 * vfov_deg);
  const int n = top > 0 ? int(std::ceil(2.0 * top / (0.8 * vfov_deg) - 1e-9)) + 1 : 1;
  std::vector<double> bands;
  for (int k = 0; k < n; ++k) bands.push_back(n == 1 ? 0.0 : top - 2.0 * top * k / (n - 1));
  return bands;
}

Trajectory::Trajectory(const TrajectoryParams& params) : p_(params) {
  bands_ = sweep_bands(p_.hfov_deg, p_.vfov_deg);
  build_sweep();
  if (p_.kind == TrajectoryKind::Handheld) build_handheld();
  if (p_.kind == TrajectoryKind::Orbit) {
    const int n = int(std::ceil(p_.duration / kWanderKnotSeconds)) + 4;
    for (int a = 0; a < 2; ++a)
      for (int k = 0; k < n; ++k)
        wander_[a].push_back(kWander * normal(hash64(p_.seed, Stream::OrbitWander, k, a)));
  }
}

void Trajectory::eval(const Segment& s, double tau, double& yaw, double& pitch) {
  tau = std::clamp(tau, 0.0, 1.0);
  switch (s.kind) {
    case 0:  // pitch ramp to or from a view straight up or down: starts and ends at rest
      yaw = s.yaw0;
      pitch = s.pitch0 + (s.pitch1 - s.pitch0) * smoothstep(tau);
      break;
    case 1:  // yaw sweep at constant speed
      yaw = s.yaw0 + (s.yaw1 - s.yaw0) * tau;
      pitch = s.pitch0;
      break;
    default: {  // U-turn: a half circle (in angle on the sphere) tangent to both bands
      const double half = 0.5 * (s.pitch0 - s.pitch1);
      const double mid = 0.5 * (s.pitch0 + s.pitch1);
      const double theta = std::numbers::pi * tau;
      yaw = s.yaw0 + s.sweep_dir * half / std::cos(mid * kDeg) * std::sin(theta);
      pitch = mid + half * std::cos(theta);
    }
  }
}

void Trajectory::build_sweep() {
  std::vector<Segment> segs;
  auto ramp = [&](double yaw, double from, double to) {
    if (from != to) segs.push_back({0, yaw, from, yaw, to, 0, 0, 0});
  };
  // Horizon first, as people capture panoramas: the bands nearest the horizon (the most
  // texture, so the first part of the map is a good anchor for alignment), then outwards
  // alternating up and down; straight up after the top band, straight down at the end.
  // Top-down: straight up, then every band from the top down, then straight down.
  // Adjacent bands are joined by U-turns, others by pitch ramps at a fixed yaw.
  std::vector<std::size_t> visit(bands_.size());
  for (std::size_t k = 0; k < visit.size(); ++k) visit[k] = k;
  const bool top_down = p_.kind == TrajectoryKind::TopDownSweep;
  if (!top_down)
    std::stable_sort(visit.begin(), visit.end(), [&](std::size_t a, std::size_t b) {
      const double fa = std::abs(bands_[a]), fb = std::abs(bands_[b]);
      return fa != fb ? fa < fb : bands_[a] > bands_[b];
    });
  double yaw = 0;
  double start = 0;                                  // the pitch the first band is reached from
  if (p_.kind == TrajectoryKind::PolesFirstSweep) {  // straight up, straight down, then on
    ramp(0, 0, 90);
    ramp(0, 90, -90);
    start = -90;
  } else if (top_down) {  // straight up first, then the bands from the top down
    ramp(0, 0, 90);
    start = 90;
  }
  ramp(0, start, bands_[visit.front()]);
  for (std::size_t k = 0; k < visit.size(); ++k) {
    const double pitch = bands_[visit[k]];
    const double dir = k % 2 == 0 ? -1.0 : 1.0;  // alternate: right first, then left
    segs.push_back({1, yaw, pitch, yaw + 360.0 * dir, pitch, 0, 0, 0});
    yaw += 360.0 * dir;
    double from = pitch;
    if (visit[k] == 0 && !top_down) {  // the top band: look straight up before going on
      ramp(yaw, from, 90);
      from = 90;
    }
    if (k + 1 == visit.size()) {
      ramp(yaw, from, -90);  // finally straight down
      break;
    }
    const std::size_t next = visit[k + 1];
    const bool adjacent = from != 90 && (next + 1 == visit[k] || visit[k] + 1 == next);
    if (adjacent)
      segs.push_back({2, yaw, from, yaw, bands_[next], dir, 0, 0});
    else
      ramp(yaw, from, bands_[next]);
  }

  // Time per segment in proportion to its angular length (constant speed), 1.5x for the eased
  // ramps so that their peak speed matches the sweeps'.
  std::vector<double> weight;
  double total = 0;
  for (const Segment& s : segs) {
    double len = 0, y0, p0;
    eval(s, 0.0, y0, p0);
    glm::dquat prev = yaw_pitch_roll(y0 * kDeg, p0 * kDeg);
    for (int i = 1; i <= 256; ++i) {
      double y, p;
      eval(s, i / 256.0, y, p);
      const glm::dquat q = yaw_pitch_roll(y * kDeg, p * kDeg);
      len += angle_between(prev, q);
      prev = q;
    }
    weight.push_back(len * (s.kind == 0 ? 1.5 : 1.0));
    total += weight.back();
  }
  double t = 0;
  for (std::size_t i = 0; i < segs.size(); ++i) {
    segs[i].start = t;
    segs[i].length = p_.duration * weight[i] / total;
    t += segs[i].length;
  }
  segments_ = std::move(segs);
}

void Trajectory::build_handheld() {
  const int n = int(std::ceil(p_.duration / kTremorKnotSeconds)) + 4;
  for (int a = 0; a < 3; ++a) {
    double walk = 0;
    for (int k = 0; k < n; ++k) {
      jitter_[a].push_back(kTremorDeg[a] * normal(hash64(p_.seed, Stream::HandheldJitter, k, a)));
      walk_[a].push_back(walk);
      walk += kWalkStep * normal(hash64(p_.seed, Stream::HandheldWalk, k, a));
    }
  }
}

void Trajectory::sweep_angles(double t, double& yaw, double& pitch) const {
  std::size_t i = 0;
  while (i + 1 < segments_.size() && t >= segments_[i + 1].start) ++i;
  const Segment& s = segments_[i];
  eval(s, s.length > 0 ? (t - s.start) / s.length : 0.0, yaw, pitch);
}

Pose Trajectory::at(double t) const {
  t = std::clamp(t, 0.0, std::max(0.0, p_.duration));
  Pose pose;
  switch (p_.kind) {
    case TrajectoryKind::Sweep:
    case TrajectoryKind::PolesFirstSweep:
    case TrajectoryKind::TopDownSweep: {
      double yaw, pitch;
      sweep_angles(t, yaw, pitch);
      pose.orientation = yaw_pitch_roll(yaw * kDeg, pitch * kDeg);
      break;
    }
    case TrajectoryKind::Handheld: {
      double yaw, pitch;
      sweep_angles(t, yaw, pitch);
      const double x = t / kTremorKnotSeconds;
      yaw += smooth_knots(jitter_[0], x);
      pitch = std::clamp(pitch + smooth_knots(jitter_[1], x), -90.0, 90.0);
      const double roll = smooth_knots(jitter_[2], x);
      pose.orientation = yaw_pitch_roll(yaw * kDeg, pitch * kDeg, roll * kDeg);
      pose.position = {smooth_knots(walk_[0], x), smooth_knots(walk_[1], x),
                       smooth_knots(walk_[2], x)};
      break;
    }
    case TrajectoryKind::Orbit: {
      // One turn around the target at kOrbitRadius, 0.4-0.6 m above it, looking at it.
      const double u = p_.duration > 0 ? t / p_.duration : 0.0;
      const double phi = 2.0 * std::numbers::pi * u;
      const double h = kOrbitHeight + 0.1 * std::sin(4.0 * std::numbers::pi * u);
      pose.position =
          p_.target + glm::dvec3(kOrbitRadius * std::sin(phi), h, kOrbitRadius * std::cos(phi));
      const double x = t / kWanderKnotSeconds;
      const glm::dvec3 look =
          p_.target + glm::dvec3(smooth_knots(wander_[0], x), 0.0, smooth_knots(wander_[1], x));
      pose.orientation = look_at(pose.position, look);
      break;
    }
  }
  return pose;
}

glm::dvec3 Trajectory::angular_velocity(double t) const {
  return sim::angular_velocity([this](double u) { return at(u).orientation; }, t, p_.duration);
}

glm::dvec3 angular_velocity(const std::function<glm::dquat(double)>& orientation_at, double t,
                            double duration) {
  const double h = 1e-4;
  const double t0 = std::max(0.0, t - h), t1 = std::min(duration, t + h);
  if (!(t1 > t0)) return glm::dvec3(0.0);
  // q(t1) = q(t0) * rel: rel is the rotation in the camera's own coordinates.
  glm::dquat rel = glm::conjugate(orientation_at(t0)) * orientation_at(t1);
  if (rel.w < 0) rel = -rel;
  const glm::dvec3 v(rel.x, rel.y, rel.z);
  const double s = glm::length(v);
  if (s < 1e-15) return glm::dvec3(0.0);
  return v * (2.0 * std::atan2(s, rel.w) / s / (t1 - t0));
}

}  // namespace arlight::sim
