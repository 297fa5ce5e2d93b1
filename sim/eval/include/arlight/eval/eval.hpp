// Image-quality figures for composites against references (issue 18, tutorial §8): PSNR and
// SSIM inside a mask, and a visible-differences map in the spirit of Daly's VDP. arlight-eval
// and the benchmarks call them.
#pragma once

#include <cstddef>
#include <filesystem>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "arlight/common/projection.hpp"

namespace arlight::eval {

struct MaskedQuality {
  double psnr_db = 0;  // 10 log10(255^2 / MSE) over the mask's pixels and the three channels
  double ssim = 0;     // mean SSIM (OpenCV's quality module, Gaussian 11x11, sigma 1.5) there
  std::size_t pixels = 0;
};

// PSNR and SSIM of `test` against `reference` (8-bit BGR, same size) over the pixels where
// `mask` (8-bit, same size) is non-zero. SSIM is computed on the whole images, then averaged
// over the mask (its windows see the surroundings, as a viewer does). An empty mask gives
// pixels = 0 and zeros; identical images give PSNR = +inf.
MaskedQuality masked_quality(const cv::Mat& reference, const cv::Mat& test, const cv::Mat& mask);

// A visible-differences predictor in the spirit of Daly's VDP (tutorial §8), on luminance:
// - both images are shown on an sRGB display (codes -> linear luminance, peak 100 cd/m^2);
// - each is split into Laplacian-pyramid bands; a band's local contrast is the band divided by
//   the next coarser Gaussian level (Peli's band-limited contrast);
// - a band's contrast threshold is 1 / CSF at its peak frequency (pixels_per_degree / 2^(k+1)
//   cycles per degree; Mannos & Sakrison's CSF scaled to a peak sensitivity of 250), raised
//   by the reference's own contrast there (contrast masking, slope 0.7);
// - the difference of the two contrasts in thresholds gives a detection probability per band
//   (a Weibull psychometric function, slope 3.5, 1 - exp(-d^3.5)), and the bands combine by
//   probability summation.
// Not modelled: colour, the eye's optics and light adaptation beyond Weber's law, orientation
// channels, time (flicker, motion): a screening figure, not a calibrated VDP.
struct VisibleDifferences {
  cv::Mat probability;  // CV_32F, per pixel, in [0, 1]
  // Share of the region's pixels whose difference is likely seen (probability >= 0.75).
  double fraction_seen = 0;
};
VisibleDifferences visible_differences(const cv::Mat& reference, const cv::Mat& test,
                                       double pixels_per_degree, const cv::Mat& region = {});
// The probability as a picture: black where no difference is seen, through red to yellow.
cv::Mat visible_differences_picture(const VisibleDifferences& vd);

// One frame of a recording scored against its reference (REC/truth/reference/).
struct FrameScore {
  std::size_t frame = 0;
  MaskedQuality object, shadow;
  double fraction_seen = 0;  // over the object and its shadow
};

struct RecordingScore {
  std::vector<FrameScore> frames;
  // Means over the frames (PSNR averaged in dB; frames whose mask is empty left out).
  MaskedQuality object, shadow;
  double fraction_seen = 0;
  double pixels_per_degree = 0;
};

// Scores composites `frames_dir`/NNNNNN.png (arlight-client --out DIR's frames/, one per
// recording frame) against the recording's references. `pixels_per_degree` <= 0 takes the
// camera's (its width over its horizontal field of view: an AR screen shows the world at its
// own angular size). When `pictures_dir` is given, writes each frame's visible-differences
// picture there as NNNNNN.png. InputError for a
// recording without references or a missing or mis-sized composite.
RecordingScore score_recording(const std::filesystem::path& recording,
                               const std::filesystem::path& frames_dir,
                               double pixels_per_degree = 0,
                               const std::filesystem::path& pictures_dir = {});

// The lighting-estimation protocol of single-image estimators (Gardner et al. 2019, LeGendre
// et al. 2019): three spheres — diffuse (albedo 1), matte silver (a Phong lobe of shininess 32)
// and a mirror — seen from the front (orthographic, 64x64, looking down -Z, +Y up), rendered
// under the estimated and the true lighting. Each sphere's images are divided by the true
// image's mean radiance, so the figures are unitless and compare across rooms:
// RMSE = sqrt(mean (e - t)^2) over the disc's pixels and channels; si-RMSE the same after the
// least-squares scale of e (sum t e / sum e^2), so only the lighting's shape counts.
struct SphereScore {
  double rmse = 0, si_rmse = 0;
};
struct LightingScore {
  SphereScore diffuse, matte_silver, mirror;
  // Angle between the two lightings' dominant lights (common/sh.hpp sh_dominant_light: the
  // direction of the first-order SH, what the clients' shadows use), degrees.
  double dominant_light_deg = 0;
};
// Both maps may be of any projection and size; both are resampled to one 256x128 lat-long
// first. InputError for a map without light.
LightingScore score_lighting(const EnvMap& truth, const EnvMap& estimate);

}  // namespace arlight::eval
