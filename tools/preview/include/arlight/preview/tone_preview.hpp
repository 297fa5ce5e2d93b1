// Previews of HDR images for people, with a choice of tone curve (tutorial §9): the global one
// of common/'s preview_pixels, or one of OpenCV's local operators, which keep detail in both the
// lamps and the shadows of a room whose range a global curve cannot hold. `arlight-maps preview
// --tone` is its shell.
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "arlight/common/image.hpp"

namespace arlight {

// Global is Reinhard's x / (1 + x) per channel (common/'s preview_pixels); the others are
// Drago et al. 2003 (adaptive logarithm, bias 0.85), Reinhard & Devlin 2005 (photoreceptor,
// adapting to each pixel's own light: light_adapt 1), Mantiuk et al. 2006 (contrast domain,
// scale 0.7).
enum class PreviewTone { Global, Drago, Reinhard, Mantiuk };
const char* preview_tone_name(PreviewTone tone);
// "global", "drago", "reinhard", "mantiuk"; InputError naming the value otherwise.
PreviewTone parse_preview_tone(const std::string& name);

struct TonePreviewOptions {
  // Exposure in stops; std::nullopt picks it so the log-average luminance maps to 0.18.
  std::optional<double> exposure_stops;
  PreviewTone tone = PreviewTone::Global;
};

// 8-bit sRGB pixels (RGB, row-major): exposure, then the tone curve, then the sRGB curve.
std::vector<std::uint8_t> tone_preview_pixels(ConstImageView img,
                                              const TonePreviewOptions& options = {});

// tone_preview_pixels() as a PNG file, written atomically.
void write_tone_preview(const std::filesystem::path& path, ConstImageView img,
                        const TonePreviewOptions& options = {});

}  // namespace arlight
