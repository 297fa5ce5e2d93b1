// The pinhole camera: orientation of the axes, the field of view, OpenCV's distortion and
// exact round trips.
#include <gtest/gtest.h>

#include <cmath>
#include <glm/geometric.hpp>
#include <numbers>
#include <opencv2/calib3d.hpp>
#include <random>

#include "arlight/common/camera.hpp"

using namespace arlight;

namespace {

CameraIntrinsics distorted() {
  CameraIntrinsics k = CameraIntrinsics::from_fov(640, 480, 60.0);
  k.fy *= 1.01;
  k.cx += 3.2, k.cy -= 2.1;
  k.distortion = {-0.21, 0.05, 0.0012, -0.0008, -0.004};  // a typical phone lens
  return k;
}

}  // namespace

TEST(Camera, ForwardIsTheCentreRightIsRightUpIsUp) {
  const PinholeCamera cam(CameraIntrinsics::from_fov(640, 480, 60.0));
  const auto centre = cam.project({0, 0, -1});
  ASSERT_TRUE(centre);
  EXPECT_NEAR(centre->x, 319.5, 1e-12);
  EXPECT_NEAR(centre->y, 239.5, 1e-12);
  EXPECT_GT(cam.project({0.1, 0, -1})->x, 319.5);  // +x to the right
  EXPECT_LT(cam.project({0, 0.1, -1})->y, 239.5);  // +y up, v grows downwards
  EXPECT_FALSE(cam.project({0, 0, 1}));            // behind
  EXPECT_FALSE(cam.project({1, 0, 0}));            // sideways
}

TEST(Camera, HorizontalFieldOfViewReachesTheImageEdges) {
  const PinholeCamera cam(CameraIntrinsics::from_fov(640, 480, 60.0));
  const double t = std::tan(30.0 * std::numbers::pi / 180.0);
  // Pixel centres are integers, so the image spans u = -0.5 (left edge) to 639.5 (right edge).
  EXPECT_NEAR(cam.project({t, 0, -1})->x, 639.5, 1e-9);
  EXPECT_NEAR(cam.project({-t, 0, -1})->x, -0.5, 1e-9);
}

TEST(Camera, DistortionMatchesOpenCvProjectPoints) {
  const CameraIntrinsics k = distorted();
  const PinholeCamera cam(k);
  const cv::Matx33d K(k.fx, 0, k.cx, 0, k.fy, k.cy, 0, 0, 1);
  std::vector<double> dist(k.distortion.begin(), k.distortion.end());
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-0.55, 0.55);
  std::vector<cv::Point3d> pts;
  for (int i = 0; i < 200; ++i) pts.push_back({u(rng), u(rng), 1.0});  // OpenCV camera coords
  std::vector<cv::Point2d> want;
  cv::projectPoints(pts, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), K, dist, want);
  for (std::size_t i = 0; i < pts.size(); ++i) {
    // OpenCV's (x, y down, z forward) is our (x, -y, -z).
    const auto got = cam.project({pts[i].x, -pts[i].y, -pts[i].z});
    ASSERT_TRUE(got);
    EXPECT_NEAR(got->x, want[i].x, 1e-9);
    EXPECT_NEAR(got->y, want[i].y, 1e-9);
  }
}

TEST(Camera, UnprojectInvertsProjectAcrossTheImage) {
  for (const CameraIntrinsics& k : {CameraIntrinsics::from_fov(640, 480, 60.0), distorted()}) {
    const PinholeCamera cam(k);
    for (int v = 0; v < 480; v += 37)
      for (int u = 0; u < 640; u += 41) {
        const glm::dvec3 d = cam.unproject({u, v});
        EXPECT_NEAR(glm::length(d), 1.0, 1e-12);
        const auto back = cam.project(d);
        ASSERT_TRUE(back);
        EXPECT_NEAR(back->x, u, 1e-6) << u << "," << v;
        EXPECT_NEAR(back->y, v, 1e-6) << u << "," << v;
      }
  }
}
