// load_intrinsics: a webcam calibration in OpenCV FileStorage form (what cv::calibrateCamera
// tools such as OpenCV's calibration sample write: camera_matrix, distortion_coefficients,
// image_width, image_height).
#include <cmath>
#include <opencv2/core.hpp>

#include "arlight/common/error.hpp"
#include "arlight/source/source.hpp"

namespace arlight::source {

CameraIntrinsics load_intrinsics(const std::filesystem::path& file, int width, int height) {
  const std::string where = "intrinsics file '" + file.string() + "'";
  if (!std::filesystem::is_regular_file(file)) throw InputError(where + ": no such file");
  cv::FileStorage fs;
  try {
    if (!fs.open(file.string(), cv::FileStorage::READ))
      throw InputError(where + ": not an OpenCV FileStorage file (YAML, XML or JSON)");
  } catch (const cv::Exception& e) {
    throw InputError(where + ": unreadable: " + e.msg);
  }
  cv::Mat k, d;
  int w = 0, h = 0;
  try {
    fs["camera_matrix"] >> k;
    fs["distortion_coefficients"] >> d;
    if (!fs["image_width"].empty()) fs["image_width"] >> w;
    if (!fs["image_height"].empty()) fs["image_height"] >> h;
  } catch (const cv::Exception& e) {
    throw InputError(where + ": malformed: " + e.msg);
  }
  if (k.empty()) throw InputError(where + ": camera_matrix: missing");
  if (k.rows != 3 || k.cols != 3) throw InputError(where + ": camera_matrix: expected 3x3");
  k.convertTo(k, CV_64F);
  CameraIntrinsics c;
  c.width = width;
  c.height = height;
  c.fx = k.at<double>(0, 0);
  c.fy = k.at<double>(1, 1);
  c.cx = k.at<double>(0, 2);
  c.cy = k.at<double>(1, 2);
  if (!(c.fx > 0 && c.fy > 0 && std::isfinite(c.fx) && std::isfinite(c.fy) &&
        std::isfinite(c.cx) && std::isfinite(c.cy)))
    throw InputError(where + ": camera_matrix: fx and fy must be positive numbers");
  if (!d.empty()) {
    d.convertTo(d, CV_64F);
    d = d.reshape(1, 1);
    if (d.cols < 4) throw InputError(where + ": distortion_coefficients: expected 4 or more");
    for (int i = 0; i < d.cols; ++i) {
      const double v = d.at<double>(0, i);
      if (!std::isfinite(v)) throw InputError(where + ": distortion_coefficients: not a number");
      if (i < 5)
        c.distortion[std::size_t(i)] = v;
      else if (v != 0)  // k4..k6, prisms, tilt: the project's camera model has k1 k2 p1 p2 k3
        throw InputError(where + ": distortion_coefficients[" + std::to_string(i) +
                         "] is not 0; only k1, k2, p1, p2, k3 are supported");
    }
  }
  // A calibration at another size of the same aspect ratio scales (the sensor is binned or
  // cropped symmetrically); another aspect ratio cannot be used.
  if (w > 0 && h > 0 && (w != width || h != height)) {
    if (std::abs(double(w) * height - double(h) * width) > 0.01 * double(w) * height)
      throw InputError(where + ": calibrated at " + std::to_string(w) + "x" + std::to_string(h) +
                       ", the camera delivers " + std::to_string(width) + "x" +
                       std::to_string(height) + " (another aspect ratio)");
    const double sx = double(width) / w, sy = double(height) / h;
    // Pixel centres are integers: a pixel edge at -0.5 maps to -0.5.
    c.fx *= sx;
    c.fy *= sy;
    c.cx = (c.cx + 0.5) * sx - 0.5;
    c.cy = (c.cy + 0.5) * sy - 0.5;
  }
  return c;
}

}  // namespace arlight::source
