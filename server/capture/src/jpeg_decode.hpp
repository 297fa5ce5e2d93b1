// JPEG frames decoded with libjpeg-turbo directly: straight to BGR (no conversion pass) and,
// when the capture reduces frames anyway, already reduced in the DCT domain.
#pragma once

#include <cstddef>
#include <cstdint>
#include <opencv2/core/mat.hpp>
#include <span>
#include <string>

namespace arlight::capture {

// A size a JPEG may have, and the DCT-domain reduction (1, 2, 4 or 8) to decode it with.
struct JpegSize {
  int width = 0, height = 0, scale = 1;
};

// Decodes `bytes`, a JPEG of one of `sizes` (`which` is set to its index), to 8-bit BGR reduced
// by that size's `scale`. On failure returns an empty image and says why in `error`: libjpeg's
// message, another size (found from the header, before any allocation), or truncation (its
// rows would be grey).
cv::Mat decode_jpeg_bgr(std::span<const std::uint8_t> bytes, std::span<const JpegSize> sizes,
                        std::size_t& which, std::string& error);

}  // namespace arlight::capture
