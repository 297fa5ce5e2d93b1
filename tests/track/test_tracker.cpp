// MarkerTracker against arlight-sim's truth: a camera orbiting a 0.2 m marker on the floor at
// about 1.1 m (tools/arlight-sim: radius 1 m, 0.4-0.6 m above it), every frame where the
// marker is fully visible; the same frames through a distorting lens; frames without the
// marker or with another id; tracking time.
#include <gtest/gtest.h>

#include <chrono>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "arlight/common/error.hpp"
#include "support/sim_cache.hpp"
#include "track/truth_stats.hpp"

using namespace arlight;
using namespace arlight::track;

namespace {

MarkerSpec spec_of(const recording::Truth& t) {
  return {t.marker->dictionary, t.marker->id, t.marker->size_m};
}

struct Errors {
  std::vector<double> cm, deg, smooth_cm, smooth_deg;
  std::size_t visible = 0, tracked = 0, ambiguous = 0;
  double seconds = 0;
};

// Tracks every frame (timed) and judges those where truth says the marker is visible.
Errors run(MarkerTracker& tracker, const test::TruthFrames& tf,
           const std::vector<cv::Mat>* images = nullptr) {
  Errors e;
  for (std::size_t i = 0; i < tf.frames.size(); ++i) {
    const cv::Mat& img = images ? (*images)[i] : tf.frames[i].bgr;
    const auto start = std::chrono::steady_clock::now();
    const TrackResult r = tracker.track(img, tf.frames[i].timestamp);
    e.seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (!tf.truth.marker_visible[i]) continue;
    ++e.visible;
    if (!r.tracked) {
      ADD_FAILURE() << "frame " << i << ": " << r.status;
      continue;
    }
    ++e.tracked;
    e.ambiguous += r.ambiguous;
    const Pose truth = test::camera_in_marker(tf.truth, i);
    e.cm.push_back(100 * glm::length(r.raw.position - truth.position));
    e.deg.push_back(angle_deg(r.raw.orientation, truth.orientation));
    if (e.cm.back() > 1.0 || e.deg.back() > 1.0)  // name the outliers
      std::printf("[ outlier  ] frame %zu: %.2f cm, %.2f deg, %s, %.3f px (other %.3f px)%s\n", i,
                  e.cm.back(), e.deg.back(), r.status.c_str(), r.reprojection_px,
                  r.alternative_px, r.edge_refined ? "" : ", cornerSubPix");
    e.smooth_cm.push_back(100 * glm::length(r.smoothed.position - truth.position));
    e.smooth_deg.push_back(angle_deg(r.smoothed.orientation, truth.orientation));
  }
  return e;
}

const test::TruthFrames& orbit() {
  static const test::TruthFrames tf = test::load_truth_frames(test::orbit_recording());
  return tf;
}

}  // namespace

TEST(MarkerTracker, OrbitPosesMatchTruthWithin1cmAnd1Degree) {
  const test::TruthFrames& tf = orbit();
  ASSERT_TRUE(tf.truth.marker.has_value());
  MarkerTracker tracker(tf.camera, spec_of(tf.truth));
  const Errors e = run(tracker, tf);
  ASSERT_GT(e.visible, 100u);  // the orbit keeps the marker in view
  EXPECT_EQ(e.tracked, e.visible);
  const test::Stats cm = test::stats(e.cm), deg = test::stats(e.deg);
  const test::Stats scm = test::stats(e.smooth_cm), sdeg = test::stats(e.smooth_deg);
  test::report("raw position error (640x480)", cm, "cm");
  test::report("raw rotation error (640x480)", deg, "deg");
  test::report("smoothed position error (640x480)", scm, "cm");
  test::report("smoothed rotation error (640x480)", sdeg, "deg");
  std::printf("[ figures  ] %zu of %zu frames ambiguous (IPPE), %.2f ms a 640x480 frame\n",
              e.ambiguous, e.tracked, 1e3 * e.seconds / double(tf.frames.size()));
  EXPECT_LT(cm.max, 1.0);
  EXPECT_LT(deg.max, 1.0);
  // Smoothing must not add lag on this fast orbit (90 deg/s, 1.6 m/s).
  EXPECT_LT(scm.p95, 1.0);
  EXPECT_LT(sdeg.p95, 1.0);
}

TEST(MarkerTracker, HandlesLensDistortion) {
  // The orbit's frames re-rendered through a barrel-distorting lens (k1 = -0.25, k2 = 0.08)
  // whose principal point is moved so that the marker lands off-centre, where distortion is
  // strong: output pixel u shows what the pinhole frame had at K undistort(u; K_lens, lens).
  // A tracker that knows the lens must stay as accurate; one that ignores it must not.
  const test::TruthFrames& tf = orbit();
  CameraIntrinsics lens = tf.camera;
  lens.distortion = {-0.25, 0.08, 0.0005, -0.0005, 0.0};
  lens.cx -= 170;
  lens.cy -= 110;
  const cv::Matx33d k(lens.fx, 0, lens.cx, 0, lens.fy, lens.cy, 0, 0, 1);
  const cv::Matx33d k0(tf.camera.fx, 0, tf.camera.cx, 0, tf.camera.fy, tf.camera.cy, 0, 0, 1);
  std::vector<cv::Point2f> grid;
  for (int y = 0; y < lens.height; ++y)
    for (int x = 0; x < lens.width; ++x) grid.emplace_back(float(x), float(y));
  std::vector<cv::Point2f> src;
  cv::undistortPoints(grid, src, k, std::vector<double>(lens.distortion.begin(), lens.distortion.end()),
                      cv::noArray(), k0);
  cv::Mat map(lens.height, lens.width, CV_32FC2, src.data());
  test::TruthFrames sub;  // every 4th frame keeps this test quick
  std::vector<cv::Mat> warped;
  sub.camera = lens;
  sub.truth = tf.truth;
  sub.truth.poses.clear();
  sub.truth.marker_visible.clear();
  for (std::size_t i = 0; i < tf.frames.size(); i += 4) {
    sub.frames.push_back(tf.frames[i]);
    sub.truth.poses.push_back(tf.truth.poses[i]);
    sub.truth.marker_visible.push_back(tf.truth.marker_visible[i]);
    cv::Mat out;
    cv::remap(tf.frames[i].bgr, out, map, cv::noArray(), cv::INTER_LINEAR);
    warped.push_back(out);
  }
  MarkerTracker knows(lens, spec_of(tf.truth));
  const Errors e = run(knows, sub, &warped);
  const test::Stats cm = test::stats(e.cm), deg = test::stats(e.deg);
  test::report("raw position error, distorted lens", cm, "cm");
  test::report("raw rotation error, distorted lens", deg, "deg");
  EXPECT_EQ(e.tracked, e.visible);
  EXPECT_LT(cm.max, 1.0);
  EXPECT_LT(deg.max, 1.0);

  TrackerOptions lax;
  lax.max_reprojection_px = 1e9;  // accept whatever the wrong model gives
  CameraIntrinsics pinhole = lens;
  pinhole.distortion = {};
  MarkerTracker ignores(pinhole, spec_of(tf.truth), lax);
  std::vector<double> wrong_cm;
  for (std::size_t i = 0; i < sub.frames.size(); ++i) {
    const TrackResult r = ignores.track(warped[i], sub.frames[i].timestamp);
    if (r.tracked)
      wrong_cm.push_back(100 * glm::length(r.raw.position - test::camera_in_marker(sub.truth, i).position));
  }
  const test::Stats w = test::stats(wrong_cm);
  test::report("position error ignoring the distortion", w, "cm");
  EXPECT_GT(w.median, 2 * cm.median);
}

TEST(MarkerTracker, NoMarkerAndWrongIdAreNotTracked) {
  const test::TruthFrames& tf = orbit();
  const std::size_t i = 30;
  ASSERT_TRUE(tf.truth.marker_visible[i]);
  MarkerTracker tracker(tf.camera, spec_of(tf.truth));
  ASSERT_TRUE(tracker.track(tf.frames[i].bgr, 0.0).tracked);

  // The same frame with the marker sheet painted over in the background's colour.
  const PinholeCamera cam(tf.camera);
  const Pose pose = tf.truth.poses[i];
  const Pose m = tf.truth.marker->pose;
  std::vector<cv::Point> sheet;
  const double h = 0.5 * tf.truth.marker->size_m * 1.6;  // the white margin included
  for (const glm::dvec2 c : {glm::dvec2(-h, h), glm::dvec2(h, h), glm::dvec2(h, -h), glm::dvec2(-h, -h)}) {
    const glm::dvec3 world = m.orientation * glm::dvec3(c, 0.0) + m.position;
    const auto px = cam.project(glm::conjugate(pose.orientation) * (world - pose.position));
    ASSERT_TRUE(px.has_value());
    sheet.emplace_back(int(px->x), int(px->y));
  }
  cv::Mat blank = tf.frames[i].bgr.clone();
  cv::fillConvexPoly(blank, sheet, cv::mean(tf.frames[i].bgr));
  MarkerTracker fresh(tf.camera, spec_of(tf.truth));
  const TrackResult none = fresh.track(blank, 1.0);
  EXPECT_FALSE(none.tracked);
  EXPECT_EQ(none.status, "no marker in view");

  // Another id: the marker is seen but it is not ours.
  MarkerSpec other = spec_of(tf.truth);
  other.id = tf.truth.marker->id + 1;
  MarkerTracker wrong(tf.camera, other);
  const TrackResult w = wrong.track(tf.frames[i].bgr, 0.0);
  EXPECT_FALSE(w.tracked);
  EXPECT_NE(w.status.find("saw " + std::to_string(tf.truth.marker->id)), std::string::npos)
      << w.status;
}

TEST(MarkerTracker, RefusesBadSpecsAndImages) {
  const CameraIntrinsics cam = CameraIntrinsics::from_fov(640, 480, 60);
  auto message = [&](const MarkerSpec& s) {
    try {
      MarkerTracker t(cam, s);
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("(no error)");
  };
  EXPECT_NE(message({"DICT_9X9_1", 0, 0.2}).find("DICT_9X9_1"), std::string::npos);
  EXPECT_NE(message({"DICT_4X4_50", 50, 0.2}).find("ids 0..49"), std::string::npos);
  EXPECT_NE(message({"DICT_4X4_50", 1, 0.0}).find("must be > 0"), std::string::npos);
  MarkerTracker t(cam, {"DICT_4X4_50", 1, 0.2});
  EXPECT_THROW(t.track(cv::Mat(240, 320, CV_8UC3), 0.0), InputError);
}

TEST(MarkerTracker, TimingAt1280x720) {
  // A short orbit at 1280x720 (same geometry, so the marker is twice as many pixels): accuracy
  // and time per frame.
  sim::SimOptions o = test::orbit_options(16, 4);
  o.width = 1280, o.height = 720;
  const test::TruthFrames tf = test::load_truth_frames(test::simulated_recording("orbit720", o));
  MarkerTracker tracker(tf.camera, spec_of(tf.truth));
  const Errors e = run(tracker, tf);
  const test::Stats cm = test::stats(e.cm), deg = test::stats(e.deg);
  test::report("raw position error (1280x720)", cm, "cm");
  test::report("raw rotation error (1280x720)", deg, "deg");
  std::printf("[ figures  ] %.2f ms a 1280x720 frame\n", 1e3 * e.seconds / double(tf.frames.size()));
  EXPECT_EQ(e.tracked, e.visible);
  EXPECT_LT(cm.max, 1.0);
  EXPECT_LT(deg.max, 1.0);
}
