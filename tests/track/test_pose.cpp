// Pose conventions (OpenCV's camera vs the project's) and the pose filter.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <opencv2/calib3d.hpp>
#include <random>

#include "arlight/common/camera.hpp"
#include "arlight/track/track.hpp"

using namespace arlight;
using namespace arlight::track;

namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

glm::dquat random_rotation(std::mt19937& rng) {
  std::normal_distribution<double> n;
  return glm::normalize(glm::dquat(n(rng), n(rng), n(rng), n(rng)));
}

glm::dmat3 F() { return glm::dmat3(1, 0, 0, 0, -1, 0, 0, 0, -1); }

}  // namespace

TEST(PoseMath, OpenCvPoseIsTheProjectsCameraInTheMarkerFrame) {
  // A camera 1 m above a marker, looking at it from an angle: the project's pose (camera ->
  // marker) turned into OpenCV's (rvec, tvec) by hand; pose_from_opencv must undo it, and
  // cv::projectPoints must agree with PinholeCamera::project on the marker's corners.
  std::mt19937 rng(1);
  const PinholeCamera cam(CameraIntrinsics::from_fov(640, 480, 60));
  for (int trial = 0; trial < 20; ++trial) {
    Pose p;
    p.position = {0.1 * trial / 20.0, -0.2, 1.0};
    const glm::dquat tilt = glm::angleAxis(0.3 * (std::uniform_real_distribution<>(-1, 1)(rng)),
                                           glm::dvec3(1, 0, 0));
    p.orientation = glm::normalize(tilt * glm::angleAxis(0.2 * trial, glm::dvec3(0, 0, 1)));
    // x_cv = F conj(q) (x_marker - p) = R x_marker + t.
    const glm::dmat3 r = F() * glm::mat3_cast(glm::conjugate(p.orientation));
    const glm::dvec3 t = -(r * p.position);
    cv::Matx33d rm;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) rm(i, j) = r[j][i];
    cv::Vec3d rvec;
    cv::Rodrigues(rm, rvec);
    const Pose back = pose_from_opencv({rvec[0], rvec[1], rvec[2]}, t);
    EXPECT_LT(angle_deg(back.orientation, p.orientation), 1e-9);
    EXPECT_LT(glm::length(back.position - p.position), 1e-12);

    const std::vector<cv::Point3d> corners = {{-0.1, 0.1, 0}, {0.1, 0.1, 0}, {0.1, -0.1, 0}};
    std::vector<cv::Point2d> px;
    const CameraIntrinsics& k = cam.intrinsics();
    cv::projectPoints(corners, rvec, cv::Vec3d(t.x, t.y, t.z),
                      cv::Matx33d(k.fx, 0, k.cx, 0, k.fy, k.cy, 0, 0, 1), cv::noArray(), px);
    for (std::size_t i = 0; i < corners.size(); ++i) {
      const glm::dvec3 xm(corners[i].x, corners[i].y, corners[i].z);
      const auto ours = cam.project(glm::conjugate(p.orientation) * (xm - p.position));
      ASSERT_TRUE(ours.has_value());
      EXPECT_NEAR(ours->x, px[i].x, 1e-9);
      EXPECT_NEAR(ours->y, px[i].y, 1e-9);
    }
  }
}

TEST(PoseMath, ComposeInverseAndAxisFlip) {
  std::mt19937 rng(2);
  for (int i = 0; i < 10; ++i) {
    const Pose a{random_rotation(rng), {1, 2, 3}}, b{random_rotation(rng), {-0.5, 0.2, 4}};
    const Pose id = compose(a, inverse(a));
    EXPECT_LT(angle_deg(id.orientation, glm::dquat(1, 0, 0, 0)), 1e-9);
    EXPECT_LT(glm::length(id.position), 1e-12);
    const glm::dvec3 x(0.3, -0.7, 2.0);
    const Pose ab = compose(a, b);
    EXPECT_LT(glm::length((ab.orientation * x + ab.position) -
                          (a.orientation * (b.orientation * x + b.position) + a.position)),
              1e-12);
    const glm::dmat3 r = glm::mat3_cast(random_rotation(rng));
    const glm::dmat3 f = flip_camera_axes(r), expect = F() * r * F();
    for (int c = 0; c < 3; ++c)
      for (int k = 0; k < 3; ++k) EXPECT_NEAR(f[c][k], expect[c][k], 1e-15);
    const glm::dquat q = random_rotation(rng);
    EXPECT_LT(angle_deg(exp_map(log_map(q)), q), 1e-9);
    EXPECT_LT(angle_deg(nearest_rotation(glm::mat3_cast(q) * 1.01), q), 1e-9);
  }
  EXPECT_NEAR(angle_deg(glm::angleAxis(0.5 * kDeg, glm::dvec3(0, 1, 0)), glm::dquat(1, 0, 0, 0)),
              0.5, 1e-12);
}

TEST(PoseFilter, RemovesJitterOfAStillCamera) {
  std::mt19937 rng(3);
  std::normal_distribution<double> n;
  PoseFilter filter;
  const Pose truth{glm::angleAxis(0.4, glm::normalize(glm::dvec3(1, 2, 3))), {0.2, 0.5, 1.0}};
  double raw_pos = 0, smooth_pos = 0, raw_rot = 0, smooth_rot = 0;
  int count = 0;
  for (int i = 0; i < 300; ++i) {
    Pose z = truth;
    z.position += 0.002 * glm::dvec3(n(rng), n(rng), n(rng));  // 2 mm
    z.orientation = z.orientation * exp_map(0.3 * kDeg * glm::dvec3(n(rng), n(rng), n(rng)));
    const Pose s = filter.update(z, i / 30.0);
    if (i < 30) continue;  // settled
    raw_pos += glm::dot(z.position - truth.position, z.position - truth.position);
    smooth_pos += glm::dot(s.position - truth.position, s.position - truth.position);
    raw_rot += std::pow(angle_deg(z.orientation, truth.orientation), 2);
    smooth_rot += std::pow(angle_deg(s.orientation, truth.orientation), 2);
    ++count;
  }
  // RMS errors at least halved.
  EXPECT_LT(std::sqrt(smooth_pos / count), 0.5 * std::sqrt(raw_pos / count));
  EXPECT_LT(std::sqrt(smooth_rot / count), 0.5 * std::sqrt(raw_rot / count));
}

TEST(PoseFilter, FollowsSteadyMotionWithoutLagAndRestartsAfterAGap) {
  PoseFilter filter;
  const glm::dvec3 v(0.5, 0.0, -0.3);                       // m/s
  const glm::dvec3 w = 60.0 * kDeg * glm::dvec3(0, 1, 0);  // 60 deg/s about the body's y
  auto at = [&](double t) { return Pose{exp_map(w * t), glm::dvec3(0.1, 0.2, 1.0) + v * t}; };
  double worst_pos = 0, worst_rot = 0;
  for (int i = 0; i < 60; ++i) {
    const double t = i / 30.0;
    const Pose s = filter.update(at(t), t);
    if (i >= 20) {
      worst_pos = std::max(worst_pos, glm::length(s.position - at(t).position));
      worst_rot = std::max(worst_rot, angle_deg(s.orientation, at(t).orientation));
    }
  }
  // A plain low-pass at these speeds trails by centimetres and degrees.
  EXPECT_LT(worst_pos, 0.0005);
  EXPECT_LT(worst_rot, 0.05);
  // Motion from rest (0 to 0.3 m/s at once): the lag stays below one frame's motion (1 cm; a
  // plain low-pass at this cut-off trails by about three frames).
  PoseFilter start;
  double spike = 0;
  for (int i = 0; i < 60; ++i) {
    const double t = i / 30.0;
    const Pose truth{glm::dquat(1, 0, 0, 0), glm::dvec3(t < 1 ? 0.0 : 0.3 * (t - 1), 0, 1)};
    spike = std::max(spike, glm::length(start.update(truth, t).position - truth.position));
  }
  EXPECT_LT(spike, 0.3 / 30.0);
  // After a gap (a lost marker) the first pose passes unfiltered.
  const Pose far{glm::dquat(1, 0, 0, 0), {5, 5, 5}};
  const Pose s = filter.update(far, 60 / 30.0 + 1.0);
  EXPECT_EQ(s.position, far.position);
}
