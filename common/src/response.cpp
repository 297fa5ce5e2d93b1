#include "arlight/common/response.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <stdexcept>

#include "arlight/common/atomic_file.hpp"
#include "arlight/common/error.hpp"

namespace arlight {

namespace {

double srgb_decode(double c) {
  return c <= 0.04045 ? c / 12.92 : std::pow((c + 0.055) / 1.055, 2.4);
}
double srgb_encode(double x) {
  x = std::clamp(x, 0.0, 1.0);
  return x <= 0.0031308 ? 12.92 * x : 1.055 * std::pow(x, 1.0 / 2.4) - 0.055;
}

// Narkowicz's ACES fit, with the exposure at which code 255 is reached fixed to kFilmicWhite.
constexpr double kFilmicWhite = 4.0;
double aces(double x) { return x * (2.51 * x + 0.03) / (x * (2.43 * x + 0.59) + 0.14); }
double filmic_encode(double x) {
  x = std::clamp(x, 0.0, 1.0);
  return srgb_encode(aces(kFilmicWhite * x) / aces(kFilmicWhite));
}

}  // namespace

CameraResponse CameraResponse::srgb() {
  CameraResponse r;
  r.name_ = "srgb";
  r.kind_ = 1;
  for (auto& ch : r.table_)
    for (int c = 0; c < 256; ++c) ch[std::size_t(c)] = float(srgb_decode(c / 255.0));
  return r;
}

CameraResponse CameraResponse::filmic() {
  CameraResponse r;
  r.name_ = "filmic";
  r.kind_ = 2;
  // The exposure of each code by bisection of the (increasing) forward curve.
  for (int c = 0; c < 256; ++c) {
    double lo = 0.0, hi = 1.0;
    for (int i = 0; i < 60; ++i) {
      const double mid = 0.5 * (lo + hi);
      (filmic_encode(mid) < c / 255.0 ? lo : hi) = mid;
    }
    for (auto& ch : r.table_) ch[std::size_t(c)] = float(c == 255 ? 1.0 : 0.5 * (lo + hi));
  }
  return r;
}

CameraResponse CameraResponse::from_table(const std::array<std::vector<float>, 3>& linear_of_code) {
  CameraResponse r;
  r.name_ = "table";
  for (int ch = 0; ch < 3; ++ch) {
    const std::vector<float>& t = linear_of_code[std::size_t(ch)];
    const std::string which = "camera response channel " + std::to_string(ch) + ": ";
    if (t.size() != 256)
      throw std::invalid_argument(which + "expected 256 values, got " + std::to_string(t.size()));
    for (std::size_t c = 0; c < 256; ++c) {
      if (!std::isfinite(t[c]) || t[c] < 0.0f)
        throw std::invalid_argument(which + "code " + std::to_string(c) +
                                    " is not a finite value >= 0");
      if (c > 0 && t[c] < t[c - 1])
        throw std::invalid_argument(which + "decreases at code " + std::to_string(c));
    }
    if (!(t[255] > 0.0f)) throw std::invalid_argument(which + "code 255 must be positive");
    for (std::size_t c = 0; c < 256; ++c) r.table_[std::size_t(ch)][c] = t[c] / t[255];
  }
  return r;
}

float CameraResponse::encode(float x, int channel) const {
  if (kind_ == 1) return float(srgb_encode(x));
  if (kind_ == 2) return float(filmic_encode(x));
  // Piecewise-linear inverse of the measured table.
  const auto& t = table_[std::size_t(channel)];
  if (x <= t[0]) return 0.0f;
  if (x >= t[255]) return 1.0f;
  const auto it = std::upper_bound(t.begin(), t.end(), x);
  const int c = int(it - t.begin());  // t[c - 1] <= x < t[c]
  const float span = t[std::size_t(c)] - t[std::size_t(c - 1)];
  const float frac = span > 0.0f ? (x - t[std::size_t(c - 1)]) / span : 0.0f;
  return (float(c - 1) + frac) / 255.0f;
}

void CameraResponse::save(const std::filesystem::path& path) const {
  nlohmann::json j;
  j["response"] = name_;
  j["linear_of_code"] = nlohmann::json::array();
  for (const auto& ch : table_) j["linear_of_code"].push_back(ch);
  write_file_atomically(path, j.dump() + "\n");
}

CameraResponse CameraResponse::named(const std::string& name_or_file) {
  if (name_or_file == "srgb") return srgb();
  if (name_or_file == "filmic") return filmic();
  return load(name_or_file);  // InputError naming the file
}

CameraResponse CameraResponse::load(const std::filesystem::path& path) {
  const std::string where = "'" + path.string() + "': ";
  std::ifstream in(path);
  if (!in) throw InputError(where + "cannot read the camera response");
  try {
    const nlohmann::json j = nlohmann::json::parse(in);
    const auto& curves = j.at("linear_of_code");
    if (!curves.is_array() || curves.size() != 3)
      throw InputError(where + "linear_of_code: expected 3 channels");
    std::array<std::vector<float>, 3> t;
    for (std::size_t ch = 0; ch < 3; ++ch) t[ch] = curves[ch].get<std::vector<float>>();
    CameraResponse r = from_table(t);
    if (j.contains("response") && j["response"].is_string()) r.name_ = j["response"];
    return r;
  } catch (const nlohmann::json::exception& e) {
    throw InputError(where + "not a camera response file: " + e.what());
  } catch (const std::invalid_argument& e) {
    throw InputError(where + e.what());
  }
}

}  // namespace arlight
