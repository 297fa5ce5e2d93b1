#include "arlight/capture/calibration.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <opencv2/photo.hpp>
#include <vector>

#include "arlight/common/error.hpp"

namespace arlight::capture {

std::optional<CalibrationMethod> parse_calibration_method(std::string_view name) {
  if (name == "robertson") return CalibrationMethod::Robertson;
  if (name == "debevec") return CalibrationMethod::Debevec;
  return std::nullopt;
}

CameraResponse calibrate_response(std::span<const cv::Mat> images,
                                  std::span<const double> exposure_times,
                                  CalibrationMethod method) {
  if (images.size() < 2)
    throw InputError("calibration needs at least 2 differently exposed images, got " +
                     std::to_string(images.size()));
  if (images.size() != exposure_times.size())
    throw InputError("calibration: " + std::to_string(images.size()) + " images but " +
                     std::to_string(exposure_times.size()) + " exposure times");
  std::vector<cv::Mat> set;
  std::vector<float> times;
  for (std::size_t i = 0; i < images.size(); ++i) {
    const cv::Mat& im = images[i];
    if (im.type() != CV_8UC3 || im.size() != images[0].size() || im.empty())
      throw InputError("calibration: image " + std::to_string(i) +
                       " is not an 8-bit colour image of the first one's size");
    if (!std::isfinite(exposure_times[i]) || !(exposure_times[i] > 0.0))
      throw InputError("calibration: image " + std::to_string(i) +
                       " has a non-positive exposure time");
    set.push_back(im);
    times.push_back(float(exposure_times[i]));
  }
  const auto [lo, hi] = std::minmax_element(times.begin(), times.end());
  if (*hi < *lo * 1.5f)
    throw InputError("calibration: the exposure times must differ (they span only " +
                     std::to_string(*hi / *lo) + "x)");

  cv::Mat curve;  // 256 x 1, CV_32FC3, BGR
  if (method == CalibrationMethod::Robertson)
    cv::createCalibrateRobertson(60, 1e-4f)->process(set, curve, times);
  else
    cv::createCalibrateDebevec(200, 10.0f)->process(set, curve, times);

  std::array<std::vector<float>, 3> table;
  for (int ch = 0; ch < 3; ++ch) {
    std::vector<float>& t = table[std::size_t(ch)];
    t.resize(256);
    for (int c = 0; c < 256; ++c) {
      const float v = curve.at<cv::Vec3f>(c)[2 - ch];  // BGR -> RGB
      t[std::size_t(c)] = std::isfinite(v) && v > 0.0f ? v : 0.0f;
    }
    // The estimate of each code comes from the pixels that happened to have it, so it wiggles
    // by a percent or two (JPEG, noise); the true curve is smooth. Average log values over
    // +-3 codes, away from the ends where clipping and black dominate.
    std::vector<float> smooth = t;
    for (int c = 4; c <= 250; ++c) {
      double sum = 0.0;
      int n = 0;
      for (int k = c - 3; k <= c + 3; ++k)
        if (t[std::size_t(k)] > 0.0f) sum += std::log(double(t[std::size_t(k)])), ++n;
      if (n > 0 && t[std::size_t(c)] > 0.0f) smooth[std::size_t(c)] = float(std::exp(sum / n));
    }
    float running = 0.0f;
    for (int c = 0; c < 256; ++c) {
      running = std::max(running, smooth[std::size_t(c)]);  // noise may dip: non-decreasing
      t[std::size_t(c)] = running;
    }
    if (!(t[128] > 0.0f))
      throw InputError("calibration failed: channel " + std::to_string(ch) + " came out black");
  }
  // Each channel is only known up to its own scale. A camera's output is white-balanced (equal
  // codes are grey), so scale red and blue to agree with green over the mid-tones; and code
  // 255, which collects every clipped exposure, gets one common value so that normalising by
  // it keeps that balance.
  const auto mid_log_mean = [](const std::vector<float>& t) {
    double sum = 0.0;
    for (int c = 64; c <= 192; ++c) sum += std::log(double(t[std::size_t(c)]));
    return sum / 129.0;
  };
  const double green = mid_log_mean(table[1]);
  float top = 0.0f;
  for (auto& t : table) {
    const float gain = float(std::exp(green - mid_log_mean(t)));
    for (float& v : t) v *= gain;
    top = std::max(top, t[255]);
  }
  for (auto& t : table) t[255] = top;
  CameraResponse r = CameraResponse::from_table(table);
  return r;
}

double response_rms_difference(const CameraResponse& a, const CameraResponse& b, int lo, int hi) {
  // One scale for all channels: a calibration that tints one channel is wrong.
  double ab = 0.0, bb = 0.0;
  for (int ch = 0; ch < 3; ++ch)
    for (int c = lo; c <= hi; ++c) {
      // Relative error: weight each code by 1 / a^2 so that the fit is in relative terms.
      const double va = a.linear(c, ch), vb = b.linear(c, ch);
      if (!(va > 0.0)) continue;
      ab += vb / va;
      bb += (vb / va) * (vb / va);
    }
  const double scale = bb > 0.0 ? ab / bb : 1.0;
  double sum = 0.0;
  int n = 0;
  for (int ch = 0; ch < 3; ++ch)
    for (int c = lo; c <= hi; ++c) {
      const double va = a.linear(c, ch), vb = b.linear(c, ch);
      if (!(va > 0.0)) continue;
      const double rel = (scale * vb - va) / va;
      sum += rel * rel;
      ++n;
    }
  return n ? std::sqrt(sum / n) : 0.0;
}

std::filesystem::path ResponseStore::path_for(std::string_view device_id) const {
  if (device_id.empty() || device_id.size() > 128 || device_id == "." || device_id == ".." ||
      !std::all_of(device_id.begin(), device_id.end(), [](char c) {
        return std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '_' || c == '-';
      }))
    throw InputError("device id '" + std::string(device_id) +
                     "' is not usable as a curve name (1-128 of A-Z a-z 0-9 . _ -)");
  return folder_ / (std::string(device_id) + ".json");
}

std::optional<CameraResponse> ResponseStore::find(std::string_view device_id) const {
  const std::filesystem::path p = path_for(device_id);
  if (!std::filesystem::exists(p)) return std::nullopt;
  return CameraResponse::load(p);
}

void ResponseStore::save(std::string_view device_id, const CameraResponse& response) const {
  std::filesystem::create_directories(folder_);
  response.save(path_for(device_id));
}

}  // namespace arlight::capture
