// Sub-pixel marker corners from its four edges: along each edge of the black square, the
// sub-pixel position where the intensity across the edge crosses halfway between the black
// border and the white quiet zone, in *linear* intensity (8-bit frames are sRGB-decoded first:
// in code values the halfway point sits about a quarter pixel towards the white, which makes
// the marker look larger and the camera closer). The edge points are undistorted, a line is
// fitted to each edge, and adjacent lines meet at the corners. Many points per edge average
// the noise that single-corner refinement (cornerSubPix) keeps.
#pragma once

#include <array>
#include <opencv2/core.hpp>
#include <optional>

namespace arlight::track::detail {

struct EdgeRefineParams {
  cv::Matx33d k;  // intrinsics
  cv::Mat dist;   // OpenCV distortion coefficients (1x5)
  bool srgb = true;
  double search_px = 3.0;  // how far across an edge to look (the first pass)
};

struct RefinedCorners {
  std::array<cv::Point2d, 4> undistorted;  // ideal pinhole pixels (K, no distortion)
  std::array<cv::Point2d, 4> distorted;    // the same in the image (K and distortion)
  int edge_points = 0;
};

// `gray`: the full-resolution 8-bit frame; `corners`: the detector's corners in cv::aruco's
// order (distorted pixels). std::nullopt when an edge has too few clean crossings (too small,
// blurred or occluded), so the caller keeps the detector's corners.
std::optional<RefinedCorners> refine_corners(const cv::Mat& gray,
                                             const std::array<cv::Point2d, 4>& corners,
                                             const EdgeRefineParams& params);

}  // namespace arlight::track::detail
