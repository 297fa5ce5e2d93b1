#include "arlight/preview/tone_preview.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/core.hpp>
#include <opencv2/core/utils/logger.hpp>
#include <opencv2/photo.hpp>

#include "arlight/common/error.hpp"
#include "arlight/common/hdr_io.hpp"

namespace arlight {

const char* preview_tone_name(PreviewTone tone) {
  switch (tone) {
    case PreviewTone::Global:
      return "global";
    case PreviewTone::Drago:
      return "drago";
    case PreviewTone::Reinhard:
      return "reinhard";
    case PreviewTone::Mantiuk:
      return "mantiuk";
  }
  return "?";
}

PreviewTone parse_preview_tone(const std::string& name) {
  for (const PreviewTone t :
       {PreviewTone::Global, PreviewTone::Drago, PreviewTone::Reinhard, PreviewTone::Mantiuk})
    if (name == preview_tone_name(t)) return t;
  throw InputError("tone '" + name + "': use global, drago, reinhard or mantiuk");
}

std::vector<std::uint8_t> tone_preview_pixels(ConstImageView img,
                                              const TonePreviewOptions& options) {
  if (options.tone == PreviewTone::Global) return preview_pixels(img, {options.exposure_stops});
  const double scale =
      std::exp2(options.exposure_stops ? *options.exposure_stops : auto_exposure_stops(img));
  // OpenCV's operators take linear BGR (positive: a tiny floor keeps their logarithms finite)
  // and return [0, 1] with their gamma (1: linear here).
  cv::Mat hdr(img.height, img.width, CV_32FC3), ldr;
  for (int y = 0; y < img.height; ++y)
    for (int x = 0; x < img.width; ++x)
      for (int c = 0; c < 3; ++c) {
        const float v = float(img.pixel(x, y)[c] * scale);
        const float exposed = std::isinf(v) && v > 0 ? std::numeric_limits<float>::max()
                              : v > 0.0f             ? v
                                                     : 0.0f;  // also NaN
        hdr.at<cv::Vec3f>(y, x)[2 - c] = std::min(exposed, 1e30f) + 1e-9f;
      }
  cv::Ptr<cv::Tonemap> op;
  switch (options.tone) {
    case PreviewTone::Drago:
      op = cv::createTonemapDrago(1.0f, 1.0f, 0.85f);
      break;
    case PreviewTone::Reinhard:
      op = cv::createTonemapReinhard(1.0f, 0.0f, 1.0f, 0.0f);
      break;
    default:
      op = cv::createTonemapMantiuk(1.0f, 0.7f, 1.0f);
      break;
  }
  // OpenCV 4.6's Drago and Mantiuk print a notice about their own multi-channel matrix
  // expressions on every call; keep it off the user's terminal.
  static const bool quiet = [] {
    cv::utils::logging::setLogLevel(cv::utils::logging::LOG_LEVEL_ERROR);
    return true;
  }();
  (void)quiet;
  op->process(hdr, ldr);
  std::vector<std::uint8_t> px(std::size_t(img.width) * img.height * 3);
  for (int y = 0; y < img.height; ++y)
    for (int x = 0; x < img.width; ++x)
      for (int c = 0; c < 3; ++c)
        px[(std::size_t(y) * img.width + x) * 3 + c] =
            srgb_code(ldr.at<cv::Vec3f>(y, x)[2 - c]);  // srgb_code takes NaN as 0
  return px;
}

void write_tone_preview(const std::filesystem::path& path, ConstImageView img,
                        const TonePreviewOptions& options) {
  write_png_rgb(path, img.width, img.height, tone_preview_pixels(img, options));
}

}  // namespace arlight
