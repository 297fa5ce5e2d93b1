// Tracking one ArUco marker: the camera's pose in the marker's frame, which is the AR scene's
// frame (thesis §5.2: the image target defines the scene's origin and scale). Detection is
// OpenCV's aruco (on a downscaled copy of the frame, for speed), then sub-pixel corners at full
// resolution from lines fitted to the marker's four edges in linear intensity (src/
// edge_refine.hpp; cornerSubPix when that fails), the pose by IPPE for squares (two candidate
// solutions, the ambiguity resolved by reprojection error and the previous pose), refined by
// Levenberg-Marquardt, then smoothed (pose_filter.hpp). Lens distortion is handled throughout:
// edge points are undistorted before the lines are fitted.
#pragma once

#include <array>
#include <glm/vec2.hpp>
#include <limits>
#include <memory>
#include <opencv2/core/mat.hpp>
#include <string>

#include "arlight/common/camera.hpp"
#include "arlight/track/pose_filter.hpp"
#include "arlight/track/pose_math.hpp"

namespace arlight::track {

struct MarkerSpec {
  std::string dictionary = "DICT_4X4_50";  // an OpenCV predefined dictionary name
  int id = 0;
  double size_m = 0;  // side of the black square, metres
};

struct TrackerOptions {
  // RMS corner reprojection error (pixels) above which a pose is refused (marker lost).
  double max_reprojection_px = 2.0;
  // IPPE's two solutions count as ambiguous when the worse one's error is below this multiple
  // of the better one's (plus 0.2 px); then the one nearer the previous pose wins.
  double ambiguity_ratio = 3.0;
  double prior_max_age_s = 0.5;  // how long the previous pose serves as the prior
  bool refine_lm = true;         // solvePnPRefineLM after IPPE
  // The detector runs on the frame downscaled to at most this width (0: full resolution); the
  // corners are refined at full resolution. 320 finds markers down to ~50 px a side in a
  // 640-wide frame at a fraction of the time full resolution takes on a textured scene.
  int detection_width = 320;
  bool edge_refinement = true;  // edge-line corners (else cornerSubPix only)
  bool srgb = true;             // frames are sRGB-encoded (decoded for the edge refinement)
  PoseFilterOptions smoothing;
};

struct TrackResult {
  bool tracked = false;
  // Why not tracked, or "tracked" (with "ambiguous" when the prior decided).
  std::string status;
  double timestamp = 0;
  // The camera's pose in the marker frame (camera -> marker: orientation rotates the
  // project's camera coordinates into marker coordinates, position is the camera centre in
  // metres), as measured and as smoothed.
  Pose raw, smoothed;
  double reprojection_px = 0;  // RMS over the four corners, the chosen (refined) pose
  double alternative_px = std::numeric_limits<double>::infinity();  // IPPE's other solution
  bool ambiguous = false;
  bool edge_refined = false;  // the corners came from the edge lines (else cornerSubPix)
  std::array<glm::dvec2, 4> corners{};  // detected, cv::aruco order (TL, TR, BR, BL), pixels
};

class MarkerTracker {
 public:
  // InputError for an unknown dictionary, an id outside it or a size that is not positive.
  MarkerTracker(const CameraIntrinsics& camera, const MarkerSpec& marker,
                const TrackerOptions& options = {});
  ~MarkerTracker();
  MarkerTracker(MarkerTracker&&) noexcept;
  MarkerTracker& operator=(MarkerTracker&&) noexcept;

  // One frame (8-bit BGR or grayscale, the camera's size) taken at `timestamp` seconds.
  TrackResult track(const cv::Mat& image, double timestamp);
  // Forget the prior and the smoothing (e.g. after a jump in the stream).
  void reset();

  const CameraIntrinsics& camera() const;
  const MarkerSpec& marker() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace arlight::track
