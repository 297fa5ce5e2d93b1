// Image-quality figures for composites against references (eval.hpp).
#include "arlight/eval/eval.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/quality.hpp>

#include "arlight/common/error.hpp"
#include "arlight/common/resample.hpp"
#include "arlight/common/sh.hpp"
#include "arlight/lighting/lighting.hpp"
#include "arlight/protocol/recording.hpp"
#include "arlight/reference/reference.hpp"
#include "arlight/truth/truth.hpp"

namespace arlight::eval {

namespace fs = std::filesystem;

namespace {

constexpr double kMaxPsnr = 100.0;  // for identical pixels (JSON has no infinity)
constexpr double kPeakSensitivity = 250;
constexpr double kMaskingSlope = 0.7, kPsychometricSlope = 3.5, kSeenProbability = 0.75;
constexpr double kDisplayPeak = 100;  // cd/m^2
constexpr double kDarkest = 0.5;      // cd/m^2: contrast is relative to no less than this

void check_pair(const cv::Mat& a, const cv::Mat& b, const char* what) {
  if (a.type() != CV_8UC3 || b.type() != CV_8UC3 || a.size() != b.size())
    throw InputError(std::string(what) + ": the images must be 8-bit BGR of one size");
}

// Display luminance (cd/m^2) of 8-bit sRGB BGR codes.
cv::Mat display_luminance(const cv::Mat& bgr) {
  cv::Mat lut(1, 256, CV_32F);
  for (int c = 0; c < 256; ++c) {
    const double v = c / 255.0;
    lut.at<float>(c) = float(v <= 0.04045 ? v / 12.92 : std::pow((v + 0.055) / 1.055, 2.4));
  }
  cv::Mat channels[3];
  cv::split(bgr, channels);
  cv::Mat b, g, r;
  cv::LUT(channels[0], lut, b);
  cv::LUT(channels[1], lut, g);
  cv::LUT(channels[2], lut, r);
  return kDisplayPeak * (0.0722 * b + 0.7152 * g + 0.2126 * r);
}

// Mannos & Sakrison's contrast sensitivity (1974), normalised to peak 1.
double csf(double cycles_per_degree) {
  const auto a = [](double f) {
    return 2.6 * (0.0192 + 0.114 * f) * std::exp(-std::pow(0.114 * f, 1.1));
  };
  static const double peak = [&] {
    double best = 0;
    for (double f = 0.5; f < 60; f += 0.01) best = std::max(best, a(f));
    return best;
  }();
  return a(cycles_per_degree) / peak;
}

// Band-limited contrasts (Peli 1990) of a luminance image: Laplacian bands over the next
// coarser Gaussian level, each at its level's size.
std::vector<cv::Mat> band_contrasts(const cv::Mat& luminance, int levels) {
  std::vector<cv::Mat> out;
  cv::Mat g = luminance;
  for (int k = 0; k < levels; ++k) {
    cv::Mat coarse, up;
    cv::pyrDown(g, coarse);
    cv::pyrUp(coarse, up, g.size());
    cv::Mat contrast = (g - up) / cv::max(up, kDarkest);
    out.push_back(contrast);
    g = coarse;
  }
  return out;
}

std::string frame_name(std::size_t i) {
  char name[32];
  std::snprintf(name, sizeof name, "%06zu", i);
  return name;
}

cv::Mat read_image(const fs::path& path, int flags) {
  cv::Mat m = cv::imread(path.string(), flags);
  if (m.empty()) throw InputError(path.string() + ": missing or not an image");
  return m;
}

}  // namespace

MaskedQuality masked_quality(const cv::Mat& reference, const cv::Mat& test, const cv::Mat& mask) {
  check_pair(reference, test, "masked_quality");
  if (mask.type() != CV_8U || mask.size() != reference.size())
    throw InputError("masked_quality: the mask must be 8-bit, the images' size");
  MaskedQuality q;
  q.pixels = std::size_t(cv::countNonZero(mask));
  if (q.pixels == 0) return q;
  cv::Mat ssim_map;
  cv::quality::QualitySSIM::compute(reference, test, ssim_map);
  const int channels = std::min(3, ssim_map.channels());
  cv::Mat ssim_float;
  ssim_map.convertTo(ssim_float, CV_MAKETYPE(CV_64F, ssim_map.channels()));
  double se = 0, ssim = 0;
  for (int y = 0; y < reference.rows; ++y) {
    const auto* m = mask.ptr<std::uint8_t>(y);
    const auto* a = reference.ptr<cv::Vec3b>(y);
    const auto* b = test.ptr<cv::Vec3b>(y);
    const auto* s = ssim_float.ptr<double>(y);
    for (int x = 0; x < reference.cols; ++x) {
      if (!m[x]) continue;
      for (int c = 0; c < 3; ++c) se += (double(a[x][c]) - b[x][c]) * (double(a[x][c]) - b[x][c]);
      for (int c = 0; c < channels; ++c) ssim += s[x * ssim_map.channels() + c] / channels;
    }
  }
  const double mse = se / double(3 * q.pixels);
  q.psnr_db = mse > 0 ? std::min(kMaxPsnr, 10.0 * std::log10(255.0 * 255.0 / mse)) : kMaxPsnr;
  q.ssim = ssim / double(q.pixels);
  return q;
}

VisibleDifferences visible_differences(const cv::Mat& reference, const cv::Mat& test,
                                       double pixels_per_degree, const cv::Mat& region) {
  check_pair(reference, test, "visible_differences");
  if (!(pixels_per_degree > 0))
    throw InputError("visible_differences: pixels per degree must be > 0");
  if (!region.empty() && (region.type() != CV_8U || region.size() != reference.size()))
    throw InputError("visible_differences: the region must be 8-bit, the images' size");
  int levels = 0;
  for (int side = std::min(reference.cols, reference.rows); side >= 8 && levels < 8; side /= 2)
    ++levels;
  const std::vector<cv::Mat> ref = band_contrasts(display_luminance(reference), levels),
                             tst = band_contrasts(display_luminance(test), levels);
  cv::Mat not_seen(reference.size(), CV_32F, cv::Scalar(1.0f));  // prod (1 - P_k)
  for (int k = 0; k < levels; ++k) {
    const double threshold =
        1.0 / (kPeakSensitivity * std::max(1e-3, csf(pixels_per_degree / std::exp2(k + 1))));
    cv::Mat masking;
    cv::pow(cv::abs(ref[std::size_t(k)]) / threshold, kMaskingSlope, masking);
    const cv::Mat elevated = threshold * cv::max(masking, 1.0);
    cv::Mat d = cv::abs(tst[std::size_t(k)] - ref[std::size_t(k)]) / elevated;
    cv::pow(d, kPsychometricSlope, d);
    cv::Mat stay;
    cv::exp(-d, stay);  // 1 - P_k
    cv::Mat full;
    cv::resize(stay, full, reference.size(), 0, 0, cv::INTER_LINEAR);
    not_seen = not_seen.mul(full);
  }
  VisibleDifferences vd;
  vd.probability = 1.0 - not_seen;
  const cv::Mat seen = vd.probability >= kSeenProbability;
  if (region.empty()) {
    vd.fraction_seen = double(cv::countNonZero(seen)) / double(seen.total());
  } else {
    const int n = cv::countNonZero(region);
    vd.fraction_seen = n > 0 ? double(cv::countNonZero(seen & (region != 0))) / n : 0.0;
  }
  return vd;
}

cv::Mat visible_differences_picture(const VisibleDifferences& vd) {
  cv::Mat codes, picture;
  vd.probability.convertTo(codes, CV_8U, 255.0);
  cv::applyColorMap(codes, picture, cv::COLORMAP_HOT);
  return picture;
}

RecordingScore score_recording(const fs::path& rec, const fs::path& frames_dir,
                               double pixels_per_degree, const fs::path& pictures_dir) {
  const fs::path dir = rec / recording::kTruthFolder / reference::kReferenceFolder;
  const fs::path manifest_path = dir / "reference.json";
  if (!fs::exists(manifest_path))
    throw InputError(rec.string() + ": no references (arlight-sim --object writes them)");
  std::vector<std::size_t> frames;
  try {
    std::ifstream in(manifest_path);
    frames = nlohmann::json::parse(in).at("frames").get<std::vector<std::size_t>>();
  } catch (const nlohmann::json::exception& e) {
    throw InputError(manifest_path.string() + ": " + e.what());
  }
  if (frames.empty()) throw InputError(manifest_path.string() + ": no frames");
  RecordingScore score;
  if (pixels_per_degree <= 0) {
    const CameraIntrinsics k = recording::read_recording(rec).camera;
    pixels_per_degree = k.width / (2.0 * std::atan(0.5 * k.width / k.fx) * 180.0 / M_PI);
  }
  score.pixels_per_degree = pixels_per_degree;
  if (!pictures_dir.empty()) fs::create_directories(pictures_dir);
  const cv::Mat cross = cv::getStructuringElement(cv::MORPH_RECT, {3, 3});
  int object_n = 0, shadow_n = 0;
  for (const std::size_t i : frames) {
    const std::string name = frame_name(i);
    const cv::Mat ref = read_image(dir / (name + ".png"), cv::IMREAD_COLOR),
                  object = read_image(dir / (name + "_object.png"), cv::IMREAD_GRAYSCALE),
                  shadow = read_image(dir / (name + "_shadow.png"), cv::IMREAD_GRAYSCALE),
                  test = read_image(frames_dir / (name + ".png"), cv::IMREAD_COLOR);
    if (test.size() != ref.size())
      throw InputError((frames_dir / (name + ".png")).string() + ": " + std::to_string(test.cols) +
                       "x" + std::to_string(test.rows) + ", the reference is " +
                       std::to_string(ref.cols) + "x" + std::to_string(ref.rows));
    // One pixel in from the object's outline (edges are sampled differently by a rasteriser),
    // and the shadow off that outline.
    cv::Mat inner, outer;
    cv::erode(object, inner, cross);
    cv::dilate(object, outer, cross);
    const cv::Mat shadow_only = shadow & ~outer;
    FrameScore f;
    f.frame = i;
    f.object = masked_quality(ref, test, inner);
    f.shadow = masked_quality(ref, test, shadow_only);
    const VisibleDifferences vd =
        visible_differences(ref, test, pixels_per_degree, object | shadow);
    f.fraction_seen = vd.fraction_seen;
    if (!pictures_dir.empty())
      cv::imwrite((pictures_dir / (name + ".png")).string(), visible_differences_picture(vd));
    if (f.object.pixels > 0) {
      score.object.psnr_db += f.object.psnr_db, score.object.ssim += f.object.ssim;
      score.object.pixels += f.object.pixels, ++object_n;
    }
    if (f.shadow.pixels > 0) {
      score.shadow.psnr_db += f.shadow.psnr_db, score.shadow.ssim += f.shadow.ssim;
      score.shadow.pixels += f.shadow.pixels, ++shadow_n;
    }
    score.fraction_seen += f.fraction_seen;
    score.frames.push_back(f);
  }
  if (object_n > 0) score.object.psnr_db /= object_n, score.object.ssim /= object_n;
  if (shadow_n > 0) score.shadow.psnr_db /= shadow_n, score.shadow.ssim /= shadow_n;
  score.fraction_seen /= double(score.frames.size());
  return score;
}

namespace {

constexpr int kSphereSize = 64;
constexpr double kMatteSilverShininess = 32;

// One sphere's image under `env`: its maps' (or, for the mirror, the environment's own) radiance
// at each disc pixel's normal or mirror direction, RGB, row-major, pixels off the disc left out.
std::vector<glm::dvec3> sphere_image(const EnvMap& map, bool at_mirror_direction) {
  const EnvSampler sampler(map);
  std::vector<glm::dvec3> out;
  for (int y = 0; y < kSphereSize; ++y)
    for (int x = 0; x < kSphereSize; ++x) {
      const double u = (x + 0.5) / kSphereSize * 2 - 1, v = 1 - (y + 0.5) / kSphereSize * 2;
      const double z2 = 1 - u * u - v * v;
      if (z2 <= 0) continue;
      const glm::dvec3 n(u, v, std::sqrt(z2));
      const glm::dvec3 view(0, 0, 1);  // towards the camera
      const glm::dvec3 dir = at_mirror_direction ? 2 * glm::dot(n, view) * n - view : n;
      out.push_back(glm::dvec3(sampler.sample(dir, 0.0)));
    }
  return out;
}

SphereScore sphere_score(const std::vector<glm::dvec3>& truth,
                         const std::vector<glm::dvec3>& estimate) {
  double mean = 0, te = 0, ee = 0;
  for (std::size_t i = 0; i < truth.size(); ++i) {
    mean += truth[i].x + truth[i].y + truth[i].z;
    te += glm::dot(truth[i], estimate[i]), ee += glm::dot(estimate[i], estimate[i]);
  }
  mean /= double(3 * truth.size());
  if (!(mean > 0)) throw InputError("score_lighting: the true lighting has no light");
  const double scale = ee > 0 ? te / ee : 0.0;
  double se = 0, si = 0;
  for (std::size_t i = 0; i < truth.size(); ++i) {
    const glm::dvec3 d = estimate[i] - truth[i], ds = scale * estimate[i] - truth[i];
    se += glm::dot(d, d), si += glm::dot(ds, ds);
  }
  const double n = double(3 * truth.size());
  return {std::sqrt(se / n) / mean, std::sqrt(si / n) / mean};
}

}  // namespace

LightingScore score_lighting(const EnvMap& truth_in, const EnvMap& estimate_in) {
  const EnvLayout layout(Projection::LatLong, 256, 128);
  const EnvMap truth = resample(truth_in, layout), estimate = resample(estimate_in, layout);
  // The diffuse and matte silver spheres shade with the lobe-averaged maps (DESIGN.md: shading
  // is kd Ld + ks Ls), computed the same way for both lightings.
  const double shininess[] = {1.0, kMatteSilverShininess};
  const EnvLayout maps_layout(Projection::LatLong, 128, 64);
  const auto maps = [&](const EnvMap& env) {
    return lighting::compute_maps(env, shininess, maps_layout, lighting::parse_method("auto")).maps;
  };
  const std::vector<EnvMap> t = maps(truth), e = maps(estimate);
  LightingScore s;
  s.diffuse = sphere_score(sphere_image(t[0], false), sphere_image(e[0], false));
  s.matte_silver = sphere_score(sphere_image(t[1], true), sphere_image(e[1], true));
  s.mirror = sphere_score(sphere_image(truth, true), sphere_image(estimate, true));
  // (an order-2 SH: bands 0 and 1)
  const glm::dvec3 a(sh_dominant_light(sh_project(truth, 2)).direction),
      b(sh_dominant_light(sh_project(estimate, 2)).direction);
  s.dominant_light_deg =
      std::acos(std::clamp(glm::dot(glm::normalize(a), glm::normalize(b)), -1.0, 1.0)) * 180.0 /
      M_PI;
  return s;
}

}  // namespace arlight::eval
