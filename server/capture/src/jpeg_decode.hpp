// JPEG frames decoded with libjpeg-turbo directly: straight to BGR (no conversion pass) and,
// when the capture reduces frames anyway, already reduced in the DCT domain.
#pragma once

#include <cstdint>
#include <opencv2/core/mat.hpp>
#include <span>
#include <string>

namespace arlight::capture {

// Decodes `bytes`, a width x height JPEG, to 8-bit BGR reduced by `scale` (1, 2, 4 or 8). On
// failure returns an empty image and says why in `error`: libjpeg's message, another size
// (found from the header, before any allocation), or truncation (its rows would be grey).
cv::Mat decode_jpeg_bgr(std::span<const std::uint8_t> bytes, int scale, int width, int height,
                        std::string& error);

}  // namespace arlight::capture
