// JPEG frames decoded with libjpeg-turbo directly: straight to BGR (no conversion pass) and,
// when the capture reduces frames anyway, already reduced in the DCT domain.
#pragma once

#include <cstdint>
#include <opencv2/core/mat.hpp>
#include <span>
#include <string>

namespace arlight::capture {

// Decodes `bytes` to 8-bit BGR, reduced by `scale` (1, 2, 4 or 8). On failure returns an empty
// image and says why in `error` (libjpeg's message; a truncated file counts as a failure, as it
// would put grey into the map).
cv::Mat decode_jpeg_bgr(std::span<const std::uint8_t> bytes, int scale, std::string& error);

}  // namespace arlight::capture
