// World-from-marker (phones), the visual gyro and the webcam orientation estimator, against
// arlight-sim's truth on an orbit around the marker (venice.exr: a textured environment).
#include <gtest/gtest.h>

#include <chrono>
#include <numbers>
#include <random>

#include "support/sim_cache.hpp"
#include "track/truth_stats.hpp"

using namespace arlight;
using namespace arlight::track;

namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

// A quicker orbit (60 frames, 2 s) with a drifting orientation sensor (1 degree/s of heading
// drift).
const test::TruthFrames& drifting_orbit() {
  static const test::TruthFrames tf = test::load_truth_frames([] {
    sim::SimOptions o = test::orbit_options(60, 3);
    o.gyro_drift_deg_per_s = 1;
    return test::simulated_recording("orbit_drift", o);
  }());
  return tf;
}

const test::TruthFrames& orbit() {
  static const test::TruthFrames tf = test::load_truth_frames(test::orbit_recording());
  return tf;
}

std::vector<TrackResult> track_all(const test::TruthFrames& tf) {
  MarkerTracker tracker(tf.camera, {tf.truth.marker->dictionary, tf.truth.marker->id,
                                    tf.truth.marker->size_m});
  std::vector<TrackResult> out;
  for (const auto& f : tf.frames) out.push_back(tracker.track(f.bgr, f.timestamp));
  return out;
}

}  // namespace

TEST(WorldFromMarker, EqualsTheMarkersTruePoseWithoutDrift) {
  const test::TruthFrames& tf = orbit();
  const std::vector<TrackResult> tracks = track_all(tf);
  WorldFromMarker w;
  std::vector<double> err;
  for (std::size_t i = 0; i < tf.frames.size(); ++i) {
    if (!tracks[i].tracked) continue;
    w.add(tf.frames[i].timestamp, *tf.frames[i].orientation, tracks[i].raw.orientation);
    if (const auto q = w.world_from_marker())
      err.push_back(angle_deg(*q, tf.truth.marker->pose.orientation));
  }
  const test::Stats s = test::stats(err);
  test::report("world_from_marker error, no drift", s, "deg");
  ASSERT_GT(s.n, 100u);
  EXPECT_LT(s.max, 0.5);
  EXPECT_LT(angle_deg(*w.world_from_marker(), tf.truth.marker->pose.orientation), 0.2);
  EXPECT_GT(w.inliers(), w.samples() / 2);
}

TEST(WorldFromMarker, FollowsHeadingDriftAndRejectsOutliers) {
  // Recorded orientation at t = R_y(drift t) * true * noise (protocol/RECORDING.md), so the
  // marker's pose in the IMU's world turns with the drift: R_y(drift t) * marker.
  const test::TruthFrames& tf = drifting_orbit();
  const std::vector<TrackResult> tracks = track_all(tf);
  WorldFromMarkerOptions o;
  o.window_s = 0.5;
  WorldFromMarker w(o);
  std::mt19937 rng(7);
  std::normal_distribution<double> n;
  const double drift = tf.truth.gyro_drift_deg_per_s * kDeg;
  ASSERT_NE(drift, 0.0);
  std::vector<double> err;
  for (std::size_t i = 0; i < tf.frames.size(); ++i) {
    if (!tracks[i].tracked) continue;
    glm::dquat marker_from_camera = tracks[i].raw.orientation;
    if (i % 5 == 2)  // every 5th frame a gross tracking error (a flipped IPPE solution, say)
      marker_from_camera = marker_from_camera * exp_map(20 * kDeg * glm::normalize(
                                                    glm::dvec3(n(rng), n(rng), n(rng))));
    const double t = tf.frames[i].timestamp;
    w.add(t, *tf.frames[i].orientation, marker_from_camera);
    const auto q = w.world_from_marker();
    if (!q || t < o.window_s) continue;
    const glm::dquat expect =
        glm::angleAxis(drift * t, glm::dvec3(0, 1, 0)) * tf.truth.marker->pose.orientation;
    err.push_back(angle_deg(*q, expect));
  }
  const test::Stats s = test::stats(err);
  test::report("world_from_marker error, 1 deg/s drift, 20% outliers", s, "deg");
  ASSERT_GT(s.n, 40u);
  // A window of 0.5 s lags the drift by about a quarter of a degree.
  EXPECT_LT(s.max, 0.6);
}

TEST(VisualGyro, IncrementalRotationsMatchTruth) {
  const test::TruthFrames& tf = orbit();
  VisualGyro gyro(tf.camera);
  std::vector<double> err, motion;
  int failed = 0;
  double seconds = 0;
  for (std::size_t i = 0; i < tf.frames.size(); ++i) {
    const auto start = std::chrono::steady_clock::now();
    const GyroStep s = gyro.update(tf.frames[i].bgr);
    seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (i == 0) {
      EXPECT_FALSE(s.ok);
      EXPECT_EQ(s.status, "first frame");
      continue;
    }
    if (!s.ok) {
      ++failed;
      ADD_FAILURE() << "frame " << i << ": " << s.status;
      continue;
    }
    const glm::dquat truth =
        glm::conjugate(tf.truth.poses[i - 1].orientation) * tf.truth.poses[i].orientation;
    err.push_back(angle_deg(s.delta, truth));
    motion.push_back(angle_deg(truth, glm::dquat(1, 0, 0, 0)));
  }
  const test::Stats e = test::stats(err), m = test::stats(motion);
  test::report("visual gyro error per frame pair", e, "deg");
  test::report("true rotation per frame pair", m, "deg");
  std::printf("[ figures  ] visual gyro %.2f ms a 640x480 frame\n",
              1e3 * seconds / double(tf.frames.size()));
  EXPECT_EQ(failed, 0);
  EXPECT_GT(m.median, 2.0);  // the test means something: the camera turns ~3 deg a frame
  EXPECT_LT(e.median, 0.1);
  EXPECT_LT(e.p95, 0.2);
  EXPECT_LT(e.max, 0.5);
}

TEST(VisualGyro, FlatImagesAreNotARotation) {
  const CameraIntrinsics cam = CameraIntrinsics::from_fov(320, 240, 60);
  VisualGyro gyro(cam);
  const cv::Mat grey(240, 320, CV_8UC3, cv::Scalar(90, 90, 90));
  EXPECT_FALSE(gyro.update(grey).ok);
  const GyroStep s = gyro.update(grey);
  EXPECT_FALSE(s.ok);
  EXPECT_NE(s.status.find("too little texture"), std::string::npos) << s.status;
}

TEST(OrientationEstimator, MarkerAnchorsAndTheGyroBridgesGaps) {
  // The webcam world is the marker frame with +Y along the marker's normal; the simulator's
  // marker lies on the floor exactly so, so the estimate should equal the true orientation.
  const test::TruthFrames& tf = orbit();
  EXPECT_LT(angle_deg(webcam_world_from_marker(), tf.truth.marker->pose.orientation), 1e-9);
  const std::vector<TrackResult> tracks = track_all(tf);
  OrientationEstimator est(tf.camera);
  std::vector<double> with_marker, in_gap;
  for (std::size_t i = 0; i < tf.frames.size(); ++i) {
    // The marker is withheld for the first 5 frames (no world frame yet) and for 1.3 s.
    const bool withheld = i < 5 || (i >= 40 && i < 80);
    const OrientationEstimate e =
        est.update(tf.frames[i].bgr, tf.frames[i].timestamp, withheld ? nullptr : &tracks[i]);
    if (i < 5) {
      EXPECT_FALSE(e.orientation.has_value()) << i;
      continue;
    }
    ASSERT_TRUE(e.orientation.has_value()) << i;
    const double d = angle_deg(*e.orientation, tf.truth.poses[i].orientation);
    if (withheld) {
      EXPECT_EQ(e.source, OrientationEstimate::Source::Gyro) << i;
      in_gap.push_back(d);
    } else {
      EXPECT_EQ(e.source, OrientationEstimate::Source::Marker) << i;
      with_marker.push_back(d);
    }
  }
  const test::Stats a = test::stats(with_marker), g = test::stats(in_gap);
  test::report("webcam orientation error with the marker", a, "deg");
  test::report("webcam orientation error, 40 frames on the gyro alone", g, "deg");
  EXPECT_LT(a.max, 0.5);
  EXPECT_LT(g.max, 1.5);
}
