// HDR image input and output through OpenImageIO: reads EXR, Radiance HDR (RGBE), PFM, PNG,
// JPEG and WebP into linear float RGB; writes EXR (half or float) with arlight metadata and
// 8-bit PNG previews. Every read is checked: a missing, truncated, unsupported or wrongly
// shaped file raises InputError naming the file and the problem; NaN, Inf and negative
// radiance are replaced by 0 and counted in the returned report, never passed on silently.
#pragma once

#include <array>
#include <cstdint>
#include <cstddef>
#include <filesystem>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "arlight/common/error.hpp"
#include "arlight/common/image.hpp"
#include "arlight/common/projection.hpp"

namespace arlight {

// What sanitisation changed in an image.
struct SanitizeReport {
  std::size_t negative = 0;  // finite values < 0, set to 0
  std::size_t nan = 0;       // NaN, set to 0
  std::size_t inf = 0;       // +-Inf, set to 0
  float most_negative = 0;   // the smallest finite value seen (<= 0)

  std::size_t total() const { return negative + nan + inf; }
  bool clean() const { return total() == 0; }
  std::string summary() const;  // e.g. "clamped 12 negative (min -149.25), 0 NaN, 0 Inf values"
};

// Replaces NaN, Inf and negative channel values with 0 and counts them.
SanitizeReport sanitize(ImageView img);

// Metadata arlight stores in its EXR files (attributes "arlight:*").
struct ImageMetadata {
  std::optional<Projection> projection;
  std::optional<double> shininess;
  std::vector<std::array<float, 3>> sh_coefficients;  // index l(l+1)+m; order = sqrt(size)
  std::optional<std::string> description;
  // A captured map's unseen texels: "none" (black), "mean" or "estimate" (arlight-capture --fill).
  std::optional<std::string> fill;
};

struct LoadOptions {
  std::size_t max_pixels = std::size_t(1) << 26;  // refuse larger images before allocating
  bool strict = false;  // NaN/Inf/negative values raise InputError instead of being clamped
};

struct LoadedImage {
  Image image;                // linear RGB
  std::string format;         // OpenImageIO's format name, e.g. "openexr", "png"
  bool decoded_srgb = false;  // 8/16-bit file whose sRGB encoding was undone
  SanitizeReport sanitized;
  ImageMetadata metadata;
};

LoadedImage load_image(const std::filesystem::path& path, const LoadOptions& options = {});

struct LoadedEnvMap {
  EnvMap env;
  LoadedImage info;  // info.image is moved into env
};

// Loads an environment map. Its projection is `expect` if given, else the file's
// arlight:projection attribute, else guessed from the shape (2:1 lat-long, 1:1 angle map,
// 1:6 cube). A shape that does not fit raises InputError.
LoadedEnvMap load_envmap(const std::filesystem::path& path,
                         std::optional<Projection> expect = std::nullopt,
                         const LoadOptions& options = {});

enum class ExrPixel { Half, Float };

// Writes an OpenEXR file (ZIP compressed) atomically: a temporary file in the same folder is
// written, then renamed over `path`, so a failed write never leaves a broken file behind.
// Throws std::runtime_error on failure.
void write_exr(const std::filesystem::path& path, ConstImageView img,
               const ImageMetadata& metadata = {}, ExrPixel pixel = ExrPixel::Half);

struct PreviewOptions {
  // Exposure in stops; std::nullopt picks it so the log-average luminance maps to 0.18.
  std::optional<double> exposure_stops;
};

// Exposure (stops) that maps the log-average luminance of the non-black pixels to 0.18.
double auto_exposure_stops(ConstImageView img);

// 8-bit sRGB pixels (RGB, row-major) for people to look at: exposure, then Reinhard's global
// x / (1 + x) per channel (tutorial §9), then the sRGB curve. The tools' local operators, which
// keep detail where a global curve cannot, are tools/preview's (OpenCV's photo module).
std::vector<std::uint8_t> preview_pixels(ConstImageView img, const PreviewOptions& options = {});

// A display-linear value in [0, 1] (clamped; NaN counts as 0) as an 8-bit sRGB code.
std::uint8_t srgb_code(float display_linear);

// 8-bit RGB pixels (width x height, row-major) as a PNG file, written atomically like write_exr.
// Throws std::invalid_argument when the pixel count disagrees with the size.
void write_png_rgb(const std::filesystem::path& path, int width, int height,
                   std::span<const std::uint8_t> rgb);
// The same with an alpha channel (4 bytes a pixel, straight alpha).
void write_png_rgba(const std::filesystem::path& path, int width, int height,
                    std::span<const std::uint8_t> rgba);

// preview_pixels() as a PNG file, written atomically like write_exr.
void write_png_preview(const std::filesystem::path& path, ConstImageView img,
                       const PreviewOptions& options = {});

}  // namespace arlight
