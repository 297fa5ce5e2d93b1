// MarkerTracker: cv::aruco detection with sub-pixel corners, IPPE-square pose with its
// two-fold ambiguity resolved, LM refinement, conversion to the project's camera convention.
#include "arlight/track/marker_tracker.hpp"

#include <algorithm>
#include <cmath>
#include <opencv2/aruco.hpp>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <utility>

#include "arlight/common/error.hpp"
#include "edge_refine.hpp"

namespace arlight::track {

namespace {

struct NamedDictionary {
  const char* name;
  cv::aruco::PREDEFINED_DICTIONARY_NAME id;
};

#define ARLIGHT_DICT(n) {#n, cv::aruco::n}
constexpr NamedDictionary kDictionaries[] = {
    ARLIGHT_DICT(DICT_4X4_50),         ARLIGHT_DICT(DICT_4X4_100),
    ARLIGHT_DICT(DICT_4X4_250),        ARLIGHT_DICT(DICT_4X4_1000),
    ARLIGHT_DICT(DICT_5X5_50),         ARLIGHT_DICT(DICT_5X5_100),
    ARLIGHT_DICT(DICT_5X5_250),        ARLIGHT_DICT(DICT_5X5_1000),
    ARLIGHT_DICT(DICT_6X6_50),         ARLIGHT_DICT(DICT_6X6_100),
    ARLIGHT_DICT(DICT_6X6_250),        ARLIGHT_DICT(DICT_6X6_1000),
    ARLIGHT_DICT(DICT_7X7_50),         ARLIGHT_DICT(DICT_7X7_100),
    ARLIGHT_DICT(DICT_7X7_250),        ARLIGHT_DICT(DICT_7X7_1000),
    ARLIGHT_DICT(DICT_ARUCO_ORIGINAL), ARLIGHT_DICT(DICT_APRILTAG_16h5),
    ARLIGHT_DICT(DICT_APRILTAG_25h9),  ARLIGHT_DICT(DICT_APRILTAG_36h10),
    ARLIGHT_DICT(DICT_APRILTAG_36h11),
};
#undef ARLIGHT_DICT

cv::Ptr<cv::aruco::Dictionary> dictionary_named(const std::string& name) {
  for (const NamedDictionary& d : kDictionaries)
    if (name == d.name) return cv::aruco::getPredefinedDictionary(d.id);
  throw InputError("marker dictionary '" + name +
                   "': not an OpenCV predefined dictionary (e.g. DICT_4X4_50)");
}

// RMS distance (pixels) between the detected corners and the marker's corners projected with
// the pose (rvec, tvec).
double reprojection_rms(const std::vector<cv::Point3d>& object,
                        const std::vector<cv::Point2d>& image, const cv::Vec3d& rvec,
                        const cv::Vec3d& tvec, const cv::Matx33d& k, const cv::Mat& dist) {
  std::vector<cv::Point2d> projected;
  cv::projectPoints(object, rvec, tvec, k, dist, projected);
  double sum = 0;
  for (std::size_t i = 0; i < image.size(); ++i) {
    const cv::Point2d d = projected[i] - image[i];
    sum += d.dot(d);
  }
  return std::sqrt(sum / double(image.size()));
}

}  // namespace

struct MarkerTracker::Impl {
  CameraIntrinsics camera;
  MarkerSpec marker;
  TrackerOptions options;
  cv::Ptr<cv::aruco::Dictionary> dictionary;
  cv::Ptr<cv::aruco::DetectorParameters> params;
  cv::Matx33d k;
  cv::Mat dist;
  std::vector<cv::Point3d> object;  // the corners in the marker frame, cv::aruco's order
  PoseFilter filter;
  std::optional<Pose> prior;  // the last tracked raw pose
  std::vector<cv::Point2f> prior_corners;  // and its corners (pixels)
  double prior_t = 0;
  cv::Mat gray, small;
  double detect_scale = 1;

  // The steps of track(), in order.
  struct Detection {
    std::vector<cv::Point2f> corners;  // ours, at the scale it was found at
    double scale = 1;
  };
  std::optional<Detection> detect(double timestamp, std::string& seen);
  std::vector<cv::Point2d> corner_points(const Detection& d, TrackResult& r, cv::Mat& dist);
  std::optional<std::pair<cv::Vec3d, cv::Vec3d>> solve(const std::vector<cv::Point2d>& image_pts,
                                                       const cv::Mat& dist, double timestamp,
                                                       TrackResult& r, bool& used_prior);
};

MarkerTracker::MarkerTracker(const CameraIntrinsics& camera, const MarkerSpec& marker,
                             const TrackerOptions& options)
    : impl_(std::make_unique<Impl>()) {
  Impl& m = *impl_;
  m.camera = camera;
  m.marker = marker;
  m.options = options;
  m.dictionary = dictionary_named(marker.dictionary);
  if (marker.id < 0 || marker.id >= m.dictionary->bytesList.rows)
    throw InputError("marker id " + std::to_string(marker.id) + ": " + marker.dictionary +
                     " has ids 0.." + std::to_string(m.dictionary->bytesList.rows - 1));
  if (!(marker.size_m > 0) || !std::isfinite(marker.size_m))
    throw InputError("marker size " + std::to_string(marker.size_m) + " m: must be > 0");
  if (camera.width < 1 || camera.height < 1 || !(camera.fx > 0) || !(camera.fy > 0))
    throw InputError("marker tracker: the camera intrinsics are not set");
  m.params = cv::aruco::DetectorParameters::create();
  // Corners are refined at full resolution below, not by the detector on the small copy.
  m.params->cornerRefinementMethod = cv::aruco::CORNER_REFINE_NONE;
  if (options.detection_width > 0 && camera.width > options.detection_width)
    m.detect_scale = double(options.detection_width) / camera.width;
  m.k = cv::Matx33d(camera.fx, 0, camera.cx, 0, camera.fy, camera.cy, 0, 0, 1);
  m.dist = cv::Mat(1, 5, CV_64F);
  for (int i = 0; i < 5; ++i) m.dist.at<double>(0, i) = camera.distortion[std::size_t(i)];
  const double h = 0.5 * marker.size_m;
  // IPPE_SQUARE wants exactly this order: top-left, top-right, bottom-right, bottom-left.
  m.object = {{-h, h, 0}, {h, h, 0}, {h, -h, 0}, {-h, -h, 0}};
  m.filter = PoseFilter(options.smoothing);
}

MarkerTracker::~MarkerTracker() = default;
MarkerTracker::MarkerTracker(MarkerTracker&&) noexcept = default;
MarkerTracker& MarkerTracker::operator=(MarkerTracker&&) noexcept = default;

const CameraIntrinsics& MarkerTracker::camera() const { return impl_->camera; }
const MarkerSpec& MarkerTracker::marker() const { return impl_->marker; }

void MarkerTracker::reset() {
  impl_->filter.reset();
  impl_->prior.reset();
}

// Finds our marker: on the reduced copy, or, not found there but seen a moment ago (small or
// oblique, its modules too thin at the reduced size), at full resolution around where it was.
// `seen` lists the ids in view.
std::optional<MarkerTracker::Impl::Detection> MarkerTracker::Impl::detect(double timestamp,
                                                                          std::string& seen) {
  std::vector<std::vector<cv::Point2f>> corners;
  std::vector<int> ids;
  if (detect_scale < 1) {
    cv::resize(gray, small, cv::Size(), detect_scale, detect_scale, cv::INTER_AREA);
    cv::aruco::detectMarkers(small, dictionary, corners, ids, params);
  } else {
    cv::aruco::detectMarkers(gray, dictionary, corners, ids, params);
  }
  for (const int id : ids) seen += (seen.empty() ? "" : ", ") + std::to_string(id);
  for (std::size_t i = 0; i < ids.size(); ++i)
    if (ids[i] == marker.id) return Detection{corners[i], detect_scale};
  if (!(detect_scale < 1 && prior && timestamp - prior_t <= options.prior_max_age_s))
    return std::nullopt;
  cv::Rect2d box = cv::boundingRect(prior_corners);
  const double grow = 0.5 * std::max(box.width, box.height);
  box = cv::Rect2d(box.x - grow, box.y - grow, box.width + 2 * grow, box.height + 2 * grow);
  const cv::Rect roi = cv::Rect(box) & cv::Rect(0, 0, gray.cols, gray.rows);
  std::vector<std::vector<cv::Point2f>> near;
  std::vector<int> near_ids;
  if (roi.area() > 0) cv::aruco::detectMarkers(gray(roi), dictionary, near, near_ids, params);
  for (std::size_t i = 0; i < near_ids.size(); ++i)
    if (near_ids[i] == marker.id) {
      for (cv::Point2f& p : near[i]) p += cv::Point2f(float(roi.x), float(roi.y));
      return Detection{near[i], 1.0};
    }
  return std::nullopt;
}

// The corners at full resolution for solvePnP (r.corners: as seen, in the distorted image),
// with the lens model solvePnP must apply to them in `dist`.
std::vector<cv::Point2d> MarkerTracker::Impl::corner_points(const Detection& d, TrackResult& r,
                                                            cv::Mat& dist) {
  // Back to full resolution (pixel centres are integers: an edge at -0.5 stays at -0.5), then
  // cornerSubPix there, with a window inside the one-module black border.
  std::vector<cv::Point2f> px = d.corners;
  for (cv::Point2f& p : px)
    p = (p + cv::Point2f(0.5f, 0.5f)) * float(1.0 / d.scale) - cv::Point2f(0.5f, 0.5f);
  const double side = 0.25 * (cv::norm(px[1] - px[0]) + cv::norm(px[2] - px[1]) +
                              cv::norm(px[3] - px[2]) + cv::norm(px[0] - px[3]));
  const int win = std::clamp(int(side / 6.0 * 0.4), 2, 6);
  cv::cornerSubPix(gray, px, cv::Size(win, win), cv::Size(-1, -1),
                   cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 40, 0.01));

  // Edge-line corners in the ideal pinhole image: solvePnP then needs no distortion model.
  std::vector<cv::Point2d> image_pts;
  std::array<cv::Point2d, 4> detected;
  for (int c = 0; c < 4; ++c) detected[std::size_t(c)] = px[std::size_t(c)];
  std::optional<detail::RefinedCorners> refined;
  if (options.edge_refinement)
    refined = detail::refine_corners(gray, detected,
                                     {k, this->dist, options.srgb, 1.5 / d.scale + 1.0});
  for (int c = 0; c < 4; ++c) {
    const cv::Point2d p = refined ? refined->distorted[std::size_t(c)] : detected[std::size_t(c)];
    r.corners[std::size_t(c)] = {p.x, p.y};
    image_pts.push_back(refined ? refined->undistorted[std::size_t(c)] : p);
  }
  // (A separate Mat: assigning zeros to a header sharing this->dist would zero the lens model.)
  dist = refined ? cv::Mat(cv::Mat::zeros(1, 5, CV_64F)) : this->dist;
  r.edge_refined = refined.has_value();
  return image_pts;
}

// IPPE for squares: up to two poses, sorted by reprojection error; of two nearly as good, the
// one nearer the previous pose. Then refined (Levenberg-Marquardt) when asked.
std::optional<std::pair<cv::Vec3d, cv::Vec3d>> MarkerTracker::Impl::solve(
    const std::vector<cv::Point2d>& image_pts, const cv::Mat& dist, double timestamp,
    TrackResult& r, bool& used_prior) {
  std::vector<cv::Mat> rvecs, tvecs;
  cv::Mat errors;
  const int n = cv::solvePnPGeneric(object, image_pts, k, dist, rvecs, tvecs, false,
                                    cv::SOLVEPNP_IPPE_SQUARE, cv::noArray(), cv::noArray(),
                                    errors);
  if (n < 1) return std::nullopt;
  std::vector<std::pair<cv::Vec3d, cv::Vec3d>> sol;
  std::vector<double> err;
  for (int i = 0; i < n; ++i) {
    sol.emplace_back(cv::Vec3d(rvecs[std::size_t(i)]), cv::Vec3d(tvecs[std::size_t(i)]));
    err.push_back(
        reprojection_rms(object, image_pts, sol.back().first, sol.back().second, k, dist));
  }
  std::size_t best = (n > 1 && err[1] < err[0]) ? 1 : 0;
  used_prior = false;
  if (n > 1) {
    const std::size_t other = 1 - best;
    r.alternative_px = err[other];
    // Nearly equal errors: a marker seen nearly head-on or small, where the two poses are
    // mirror images about the line of sight. The previous pose (if recent) decides.
    r.ambiguous = err[other] < options.ambiguity_ratio * err[best] + 0.2;
    if (r.ambiguous && prior && timestamp - prior_t <= options.prior_max_age_s) {
      used_prior = true;
      auto dist_to_prior = [&](std::size_t i) {
        const Pose p = pose_from_opencv({sol[i].first[0], sol[i].first[1], sol[i].first[2]},
                                        {sol[i].second[0], sol[i].second[1], sol[i].second[2]});
        return angle_deg(p.orientation, prior->orientation);
      };
      if (dist_to_prior(other) < dist_to_prior(best)) best = other;
    }
  }
  cv::Vec3d rvec = sol[best].first, tvec = sol[best].second;
  if (options.refine_lm)
    cv::solvePnPRefineLM(object, image_pts, k, dist, rvec, tvec,
                         cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 20,
                                          1e-10));
  return std::pair{rvec, tvec};
}

TrackResult MarkerTracker::track(const cv::Mat& image, double timestamp) {
  Impl& m = *impl_;
  TrackResult r;
  r.timestamp = timestamp;
  if (image.empty() || image.depth() != CV_8U || image.cols != m.camera.width ||
      image.rows != m.camera.height)
    throw InputError("marker tracker: expected an 8-bit " + std::to_string(m.camera.width) + "x" +
                     std::to_string(m.camera.height) + " image, got " +
                     std::to_string(image.cols) + "x" + std::to_string(image.rows));
  if (image.channels() == 3)
    cv::cvtColor(image, m.gray, cv::COLOR_BGR2GRAY);
  else if (image.channels() == 1)
    m.gray = image;
  else
    throw InputError("marker tracker: expected a BGR or grayscale image");

  auto lost = [&](std::string why) {
    r.status = std::move(why);
    m.filter.reset();  // the next sighting starts the smoothing afresh
    return r;
  };

  std::string seen;
  const std::optional<Impl::Detection> found = m.detect(timestamp, seen);
  if (!found)
    return lost(seen.empty() ? "no marker in view"
                             : "marker " + std::to_string(m.marker.id) + " not in view (saw " +
                                   seen + ")");
  cv::Mat dist;
  const std::vector<cv::Point2d> image_pts = m.corner_points(*found, r, dist);
  bool used_prior = false;
  const auto pose = m.solve(image_pts, dist, timestamp, r, used_prior);
  if (!pose) return lost("no pose for the detected corners");
  const auto& [rvec, tvec] = *pose;
  r.reprojection_px = reprojection_rms(m.object, image_pts, rvec, tvec, m.k, dist);
  if (!(r.reprojection_px <= m.options.max_reprojection_px) || tvec[2] <= 0)
    return lost("marker " + std::to_string(m.marker.id) + " refused: reprojection error " +
                std::to_string(r.reprojection_px) + " px > " +
                std::to_string(m.options.max_reprojection_px));

  r.raw = pose_from_opencv({rvec[0], rvec[1], rvec[2]}, {tvec[0], tvec[1], tvec[2]});
  r.smoothed = m.filter.update(r.raw, timestamp);
  r.tracked = true;
  r.status = !r.ambiguous ? "tracked"
              : used_prior ? "tracked (ambiguous: the previous pose decided)"
                           : "tracked (ambiguous: the lower reprojection error decided)";
  m.prior = r.raw;
  m.prior_t = timestamp;
  m.prior_corners.clear();
  for (const glm::dvec2& c : r.corners) m.prior_corners.emplace_back(float(c.x), float(c.y));
  return r;
}

}  // namespace arlight::track
