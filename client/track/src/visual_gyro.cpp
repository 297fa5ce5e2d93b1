// VisualGyro: frame-to-frame rotation from sparse optical flow, for cameras without an IMU.
#include <cmath>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>

#include "arlight/common/error.hpp"
#include "arlight/track/orientation.hpp"

namespace arlight::track {

namespace {

cv::Vec3d bearing(const cv::Point2f& n) { return cv::normalize(cv::Vec3d(n.x, n.y, 1.0)); }

// The rotation R minimising sum |b1 - R b0|^2 over the used pairs (Kabsch): the SVD of
// sum b1 b0^T, with the determinant forced to +1.
cv::Matx33d kabsch(const std::vector<cv::Vec3d>& b0, const std::vector<cv::Vec3d>& b1,
                   const std::vector<bool>& use) {
  cv::Matx33d m = cv::Matx33d::zeros();
  for (std::size_t i = 0; i < b0.size(); ++i)
    if (use[i]) m += b1[i] * b0[i].t();
  cv::Matx33d u, vt;
  cv::Matx31d w;
  cv::SVD::compute(m, w, u, vt);
  cv::Matx33d d = cv::Matx33d::eye();
  if (cv::determinant(u * vt) < 0) d(2, 2) = -1;
  return u * d * vt;
}

}  // namespace

struct VisualGyro::Impl {
  VisualGyroOptions o;
  CameraIntrinsics camera;  // of the (possibly downscaled) frames the gyro works on
  double scale = 1;         // gyro frame / input frame
  cv::Matx33d k;
  cv::Mat dist;
  cv::Mat prev, gray;
  std::vector<cv::Mat> prev_pyr, pyr;
  int in_width = 0, in_height = 0;
};

VisualGyro::VisualGyro(const CameraIntrinsics& camera, const VisualGyroOptions& options)
    : impl_(std::make_unique<Impl>()) {
  Impl& m = *impl_;
  if (camera.width < 1 || camera.height < 1 || !(camera.fx > 0) || !(camera.fy > 0))
    throw InputError("visual gyro: the camera intrinsics are not set");
  m.o = options;
  m.in_width = camera.width;
  m.in_height = camera.height;
  m.camera = camera;
  if (options.max_width > 0 && camera.width > options.max_width) {
    m.scale = double(options.max_width) / camera.width;
    m.camera.width = options.max_width;
    m.camera.height = int(std::lround(camera.height * m.scale));
    // Pixel centres are integers: an edge at -0.5 stays at -0.5.
    m.camera.fx *= m.scale;
    m.camera.fy *= m.scale;
    m.camera.cx = (camera.cx + 0.5) * m.scale - 0.5;
    m.camera.cy = (camera.cy + 0.5) * m.scale - 0.5;
  }
  m.k = cv::Matx33d(m.camera.fx, 0, m.camera.cx, 0, m.camera.fy, m.camera.cy, 0, 0, 1);
  m.dist = cv::Mat(1, 5, CV_64F);
  for (int i = 0; i < 5; ++i) m.dist.at<double>(0, i) = camera.distortion[std::size_t(i)];
}

VisualGyro::~VisualGyro() = default;
VisualGyro::VisualGyro(VisualGyro&&) noexcept = default;
VisualGyro& VisualGyro::operator=(VisualGyro&&) noexcept = default;

void VisualGyro::reset() {
  impl_->prev.release();
  impl_->prev_pyr.clear();
}

GyroStep VisualGyro::update(const cv::Mat& image) {
  Impl& m = *impl_;
  GyroStep step;
  if (image.empty() || image.depth() != CV_8U || image.cols != m.in_width ||
      image.rows != m.in_height || (image.channels() != 1 && image.channels() != 3))
    throw InputError("visual gyro: expected an 8-bit BGR or gray " + std::to_string(m.in_width) +
                     "x" + std::to_string(m.in_height) + " image, got " +
                     std::to_string(image.cols) + "x" + std::to_string(image.rows));
  cv::Mat g = image;
  if (image.channels() == 3) cv::cvtColor(image, g, cv::COLOR_BGR2GRAY);
  if (m.scale != 1)
    cv::resize(g, m.gray, cv::Size(m.camera.width, m.camera.height), 0, 0, cv::INTER_AREA);
  else
    m.gray = g.clone();
  const cv::Size win(m.o.lk_window, m.o.lk_window);
  m.pyr.clear();
  cv::buildOpticalFlowPyramid(m.gray, m.pyr, win, m.o.lk_levels);

  auto finish = [&](std::string status) {
    step.status = std::move(status);
    std::swap(m.prev, m.gray);
    std::swap(m.prev_pyr, m.pyr);
    return step;
  };
  if (m.prev.empty()) return finish("first frame");

  // Corners in the previous frame, followed forwards and back.
  std::vector<cv::Point2f> p0, p1, back;
  cv::goodFeaturesToTrack(m.prev, p0, m.o.max_features, m.o.feature_quality, m.o.min_distance_px);
  if (int(p0.size()) < m.o.min_inliers)
    return finish("too little texture (" + std::to_string(p0.size()) + " corners)");
  std::vector<std::uint8_t> st, st_back;
  std::vector<float> err;
  const cv::TermCriteria term(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 30, 0.01);
  cv::calcOpticalFlowPyrLK(m.prev_pyr, m.pyr, p0, p1, st, err, win, m.o.lk_levels, term);
  back = p0;
  cv::calcOpticalFlowPyrLK(m.pyr, m.prev_pyr, p1, back, st_back, err, win, m.o.lk_levels, term,
                           cv::OPTFLOW_USE_INITIAL_FLOW);
  std::vector<cv::Point2f> a, b;
  for (std::size_t i = 0; i < p0.size(); ++i) {
    const cv::Point2f d = back[i] - p0[i];
    if (st[i] && st_back[i] && d.dot(d) <= m.o.max_fb_error_px * m.o.max_fb_error_px) {
      a.push_back(p0[i]);
      b.push_back(p1[i]);
    }
  }
  step.tracked = int(a.size());
  if (step.tracked < m.o.min_inliers)
    return finish("optical flow lost the features (" + std::to_string(a.size()) + " followed)");

  // Undistorted normalised coordinates: there a rotating camera's homography is R itself
  // (H_normalised = K^-1 H_pixels K).
  std::vector<cv::Point2f> na, nb;
  cv::undistortPoints(a, na, m.k, m.dist);
  cv::undistortPoints(b, nb, m.k, m.dist);
  const double f = 0.5 * (m.camera.fx + m.camera.fy);
  std::vector<std::uint8_t> mask;
  const cv::Mat h = cv::findHomography(na, nb, cv::RANSAC, m.o.ransac_px / f, mask, 2000, 0.999);
  if (h.empty()) return finish("no homography between the frames");

  // Least-squares rotation on the RANSAC inliers' bearings, then once more without those whose
  // residual exceeds the threshold (the homography tolerates what a rotation cannot).
  std::vector<cv::Vec3d> b0, b1;
  std::vector<bool> use;
  for (std::size_t i = 0; i < na.size(); ++i) {
    b0.push_back(bearing(na[i]));
    b1.push_back(bearing(nb[i]));
    use.push_back(mask[i] != 0);
  }
  cv::Matx33d r = kabsch(b0, b1, use);
  const double limit = m.o.ransac_px / f;
  for (int pass = 0; pass < 2; ++pass) {
    for (std::size_t i = 0; i < b0.size(); ++i) use[i] = cv::norm(b1[i] - r * b0[i]) <= limit;
    r = kabsch(b0, b1, use);
  }
  double sum = 0;
  int inliers = 0;
  for (std::size_t i = 0; i < b0.size(); ++i)
    if (use[i]) {
      sum += cv::norm(b1[i] - r * b0[i], cv::NORM_L2SQR);
      ++inliers;
    }
  step.inliers = inliers;
  if (inliers < m.o.min_inliers)
    return finish("too few features agree on a rotation (" + std::to_string(inliers) + ")");
  step.residual_px = std::sqrt(sum / inliers) * f;

  // r maps the previous OpenCV camera's bearings to the current one's: x_cur = r x_prev. In
  // the project's camera axes that is F r F; delta (current -> previous) is its transpose.
  glm::dmat3 cur_from_prev;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) cur_from_prev[j][i] = r(i, j);
  step.delta = glm::conjugate(nearest_rotation(flip_camera_axes(cur_from_prev)));
  step.ok = true;
  return finish("ok");
}

}  // namespace arlight::track
