#include "arlight/common/hdr_io.hpp"

#include <OpenImageIO/imageio.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <fstream>
#include <limits>
#include <mutex>
#include <random>
#include <span>
#include <sstream>
#include <stdexcept>
#include <string_view>
#include <system_error>

#include "arlight/common/atomic_file.hpp"

namespace arlight {

namespace fs = std::filesystem;

namespace {

constexpr const char* kAttrProjection = "arlight:projection";
constexpr const char* kAttrShininess = "arlight:shininess";
constexpr const char* kAttrShOrder = "arlight:sh_order";
constexpr const char* kAttrShCoefficients = "arlight:sh_coefficients";
constexpr const char* kAttrDescription = "ImageDescription";
constexpr const char* kAttrFill = "arlight:fill";

std::string quoted(const fs::path& p) {
  // Built piecewise: `"'" + p.string() + "'"` trips GCC 12's false -Wrestrict (PR 105329).
  std::string s(1, '\'');
  s.append(p.string());
  s.push_back('\'');
  return s;
}

float srgb_to_linear(float v) {
  return v <= 0.04045f ? v / 12.92f : std::pow((v + 0.055f) / 1.055f, 2.4f);
}

float linear_to_srgb(float v) {
  return v <= 0.0031308f ? 12.92f * v : 1.055f * std::pow(v, 1.0f / 2.4f) - 0.055f;
}

ImageMetadata read_metadata(const OIIO::ImageSpec& spec, const fs::path& path) {
  ImageMetadata md;
  const std::string proj = spec.get_string_attribute(kAttrProjection);
  if (!proj.empty()) {
    md.projection = parse_projection(proj);
    if (!md.projection)
      throw InputError(quoted(path) + ": unknown " + kAttrProjection + " '" + proj +
                       "' (expected anglemap, latlong or cube)");
  }
  if (const std::string fill = spec.get_string_attribute(kAttrFill); !fill.empty())
    md.fill = fill;
  if (const auto* p = spec.find_attribute(kAttrShininess)) {
    if (p->type() != OIIO::TypeFloat)
      throw InputError(quoted(path) + ": attribute " + kAttrShininess + " is not a float");
    md.shininess = *static_cast<const float*>(p->data());
  }
  if (const auto* p = spec.find_attribute(kAttrShCoefficients)) {
    const OIIO::TypeDesc t = p->type();
    const std::size_t n =
        std::size_t(p->nvalues()) * std::size_t(t.aggregate) * std::size_t(std::max(1, t.arraylen));
    if (t.basetype != OIIO::TypeDesc::FLOAT || n % 3 != 0)
      throw InputError(quoted(path) + ": attribute " + kAttrShCoefficients +
                       " must be a float array of RGB triples");
    const std::size_t count = n / 3;
    const auto order = std::size_t(std::llround(std::sqrt(double(count))));
    if (order * order != count)
      throw InputError(quoted(path) + ": attribute " + kAttrShCoefficients + " holds " +
                       std::to_string(count) + " triples, not a square number (order^2)");
    const int declared = spec.get_int_attribute(kAttrShOrder, int(order));
    if (std::size_t(declared) != order)
      throw InputError(quoted(path) + ": " + kAttrShOrder + " is " + std::to_string(declared) +
                       " but " + kAttrShCoefficients + " holds order " + std::to_string(order));
    const float* v = static_cast<const float*>(p->data());
    md.sh_coefficients.resize(count);
    for (std::size_t i = 0; i < count; ++i)
      md.sh_coefficients[i] = {v[3 * i], v[3 * i + 1], v[3 * i + 2]};
  }
  const std::string desc = spec.get_string_attribute(kAttrDescription);
  if (!desc.empty()) md.description = desc;
  return md;
}

void ensure_parent(const fs::path& path) {
  if (path.has_parent_path()) fs::create_directories(path.parent_path());
}

// Writes with OpenImageIO to a temporary sibling, then renames it over `path`. `row_bytes` is
// the distance between rows of `pixels` (so views into larger images need no copy).
void write_atomically(const fs::path& path, const OIIO::ImageSpec& spec, const void* pixels,
                      OIIO::TypeDesc pixel_type, std::ptrdiff_t row_bytes) {
  ensure_parent(path);
  auto out = OIIO::ImageOutput::create(path.string());
  if (!out) throw std::runtime_error("cannot write " + quoted(path) + ": " + OIIO::geterror());
  const fs::path tmp = temp_sibling(path);
  bool ok = out->open(tmp.string(), spec) &&
            out->write_image(pixel_type, pixels, OIIO::AutoStride, row_bytes);
  ok = out->close() && ok;
  if (!ok) {
    const std::string err = out->geterror();
    std::error_code ec;
    fs::remove(tmp, ec);
    throw std::runtime_error("cannot write " + quoted(path) + ": " + err);
  }
  std::error_code ec;
  fs::rename(tmp, path, ec);
  if (ec) {
    fs::remove(tmp, ec);
    throw std::runtime_error("cannot write " + quoted(path) + ": rename failed: " + ec.message());
  }
}

}  // namespace

std::string SanitizeReport::summary() const {
  std::ostringstream s;
  s << "clamped " << negative << " negative";
  if (negative) s << " (min " << most_negative << ")";
  s << ", " << nan << " NaN, " << inf << " Inf values to 0";
  return s.str();
}

SanitizeReport sanitize(ImageView img) {
  SanitizeReport r;
  for (int y = 0; y < img.height; ++y) {
    float* p = img.pixel(0, y);
    for (int i = 0; i < 3 * img.width; ++i) {
      const float v = p[i];
      if (std::isnan(v)) {
        ++r.nan, p[i] = 0.0f;
      } else if (std::isinf(v)) {
        ++r.inf, p[i] = 0.0f;
      } else if (v < 0.0f) {
        ++r.negative, r.most_negative = std::min(r.most_negative, v), p[i] = 0.0f;
      }
    }
  }
  return r;
}

namespace {

// OpenEXR 3.1 (Debian 12) allocates each header attribute at the size the file claims before it
// reads it: a 437-byte file claiming a 1.7 GB string made `make fuzz` run out of memory (input
// kept in tests/fuzz/corpus/hdr_image/). So an EXR's headers (every part's) are walked first and
// an attribute larger than the rest of the file is refused, naming it.
void check_exr_headers(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::uint32_t magic = 0, version = 0;
  if (!in.read(reinterpret_cast<char*>(&magic), 4) || magic != 20000630u) return;  // not EXR
  if (!in.read(reinterpret_cast<char*>(&version), 4)) return;  // OpenEXR says what is wrong
  std::error_code ec;
  const std::uintmax_t file_size = fs::file_size(path, ec);
  if (ec) return;
  const bool multipart = version & 0x1000;
  const auto read_name = [&](std::string& name) {
    name.clear();
    for (char c; in.get(c);) {
      if (c == '\0') return true;
      if (name.size() >= 255) return false;
      name += c;
    }
    return false;
  };
  for (std::string name, type;;) {
    if (!read_name(name)) return;  // cut short: OpenEXR reports it
    if (name.empty()) {            // the end of a header
      if (!multipart || in.peek() == 0 || in.peek() == EOF) return;
      continue;  // the next part's header
    }
    std::int32_t size = 0;
    if (!read_name(type) || !in.read(reinterpret_cast<char*>(&size), 4)) return;
    const std::uintmax_t left = file_size - std::uintmax_t(in.tellg());
    if (size < 0 || std::uintmax_t(size) > left)
      throw InputError(quoted(path) + ": EXR header attribute '" + name + "' (" + type +
                       ") claims " + std::to_string(size) + " bytes, but the file has " +
                       std::to_string(left) + " left");
    in.seekg(size, std::ios::cur);
  }
}

// The same for PNG: libpng allocates a chunk at the length the file claims (the hdr_image
// fuzzer's 280-byte PNG whose tEXt chunk claims 1.6 GB ran it out of memory; kept in its
// corpus), so the chunks are walked first and one longer than the rest of the file is refused.
void check_png_chunks(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  char signature[8];
  if (!in.read(signature, 8) || std::string_view(signature, 8) != "\x89PNG\r\n\x1a\n") return;
  std::error_code ec;
  const std::uintmax_t file_size = fs::file_size(path, ec);
  if (ec) return;
  for (unsigned char head[8]; in.read(reinterpret_cast<char*>(head), 8);) {
    const std::uint32_t length = std::uint32_t(head[0]) << 24 | std::uint32_t(head[1]) << 16 |
                                 std::uint32_t(head[2]) << 8 | std::uint32_t(head[3]);
    std::string type(reinterpret_cast<const char*>(head + 4), 4);
    if (!std::all_of(type.begin(), type.end(),
                     [](char c) { return std::isalpha(static_cast<unsigned char>(c)) != 0; })) {
      char hex[16];
      std::snprintf(hex, sizeof hex, "0x%02x%02x%02x%02x", head[4], head[5], head[6], head[7]);
      type = hex;
    }
    const std::uintmax_t left = file_size - std::uintmax_t(in.tellg());
    if (std::uintmax_t(length) + 4 > left)  // its data and CRC
      throw InputError(quoted(path) + ": PNG chunk " + type + " claims " + std::to_string(length) +
                       " bytes, but the file has " + std::to_string(left) + " left");
    if (type == "IEND") return;
    in.seekg(std::streamoff(length) + 4, std::ios::cur);
  }
}

}  // namespace

LoadedImage load_image(const fs::path& path, const LoadOptions& options) {
  std::error_code ec;
  if (!fs::exists(path, ec)) throw InputError(quoted(path) + ": no such file");
  if (fs::is_directory(path, ec)) throw InputError(quoted(path) + ": is a directory, not an image");
  check_exr_headers(path);
  check_png_chunks(path);
  auto in = OIIO::ImageInput::open(path.string());
  if (!in) {
    std::string err = OIIO::geterror();
    if (err.empty()) err = "not an image format OpenImageIO can read";
    throw InputError(quoted(path) + ": cannot open as an image: " + err);
  }
  const OIIO::ImageSpec spec = in->spec();
  LoadedImage out;
  out.format = in->format_name();
  if (spec.width <= 0 || spec.height <= 0 || spec.nchannels <= 0)
    throw InputError(quoted(path) + ": empty image (" + std::to_string(spec.width) + "x" +
                     std::to_string(spec.height) + ", " + std::to_string(spec.nchannels) +
                     " channels)");
  if (spec.depth > 1) throw InputError(quoted(path) + ": volume images are not supported");
  const std::size_t pixels = std::size_t(spec.width) * std::size_t(spec.height);
  if (pixels > options.max_pixels)
    throw InputError(quoted(path) + ": " + std::to_string(spec.width) + "x" +
                     std::to_string(spec.height) + " is larger than the limit of " +
                     std::to_string(options.max_pixels) + " pixels");
  out.metadata = read_metadata(spec, path);

  // RGB(A...) keeps the first three channels; grey (+ alpha) replicates the first.
  const int nch = spec.nchannels >= 3 ? 3 : 1;
  std::vector<float> buf(pixels * std::size_t(nch));
  if (!in->read_image(0, 0, 0, nch, OIIO::TypeDesc::FLOAT, buf.data())) {
    std::string err = in->geterror();
    if (err.empty()) err = "read failed";
    throw InputError(quoted(path) + ": cannot read pixels (truncated or corrupt?): " + err);
  }
  in->close();

  out.image = Image(spec.width, spec.height);
  float* dst = out.image.data();
  for (std::size_t i = 0; i < pixels; ++i)
    for (int c = 0; c < 3; ++c) dst[3 * i + c] = buf[i * nch + (nch == 3 ? c : 0)];

  // 8/16-bit files hold display-encoded values; undo the sRGB curve unless they say linear.
  const bool integer_data = !spec.format.is_floating_point();
  const std::string cs = spec.get_string_attribute("oiio:ColorSpace");
  if (integer_data && cs != "linear" && cs != "Linear") {
    for (float& v : out.image.storage()) v = srgb_to_linear(v);
    out.decoded_srgb = true;
  }
  out.sanitized = sanitize(out.image.view());
  if (options.strict && !out.sanitized.clean())
    throw InputError(quoted(path) +
                     ": invalid pixel values: " + std::to_string(out.sanitized.negative) +
                     " negative, " + std::to_string(out.sanitized.nan) + " NaN, " +
                     std::to_string(out.sanitized.inf) + " Inf");
  return out;
}

LoadedEnvMap load_envmap(const fs::path& path, std::optional<Projection> expect,
                         const LoadOptions& options) {
  LoadedImage info = load_image(path, options);
  const int w = info.image.width(), h = info.image.height();
  std::optional<Projection> proj = expect ? expect : info.metadata.projection;
  if (!proj) proj = EnvLayout::guess_projection(w, h);
  if (!proj)
    throw InputError(quoted(path) + ": " + std::to_string(w) + "x" + std::to_string(h) +
                     " is not an environment map shape (lat-long 2N x N, angle map N x N, "
                     "cube N x 6N)");
  try {
    EnvLayout layout(*proj, w, h);
    Image img = std::move(info.image);
    return {EnvMap(layout, std::move(img)), std::move(info)};
  } catch (const std::invalid_argument& e) {
    throw InputError(quoted(path) + ": " + e.what());
  }
}

void write_exr(const fs::path& path, ConstImageView img, const ImageMetadata& md, ExrPixel pixel) {
  OIIO::ImageSpec spec(img.width, img.height, 3,
                       pixel == ExrPixel::Half ? OIIO::TypeDesc::HALF : OIIO::TypeDesc::FLOAT);
  spec.attribute("compression", "zip");
  if (md.projection) spec.attribute(kAttrProjection, std::string(projection_name(*md.projection)));
  if (md.shininess) spec.attribute(kAttrShininess, float(*md.shininess));
  if (md.fill) spec.attribute(kAttrFill, *md.fill);
  if (!md.sh_coefficients.empty()) {
    const auto order = int(std::llround(std::sqrt(double(md.sh_coefficients.size()))));
    if (std::size_t(order) * std::size_t(order) != md.sh_coefficients.size())
      throw std::invalid_argument("write_exr: SH coefficient count is not a square");
    spec.attribute(kAttrShOrder, order);
    spec.attribute(kAttrShCoefficients,
                   OIIO::TypeDesc(OIIO::TypeDesc::FLOAT, int(md.sh_coefficients.size() * 3)),
                   md.sh_coefficients.data());
  }
  if (md.description) spec.attribute(kAttrDescription, *md.description);
  write_atomically(path, spec, img.data, OIIO::TypeDesc::FLOAT,
                   img.stride * std::ptrdiff_t(sizeof(float)));
}

double auto_exposure_stops(ConstImageView img) {
  double log_sum = 0.0;
  std::size_t n = 0;
  for (int y = 0; y < img.height; ++y)
    for (int x = 0; x < img.width; ++x) {
      const glm::vec3 v = img.at(x, y);
      const double lum = luminance(glm::dvec3(v));
      if (lum > 0.0 && std::isfinite(lum)) log_sum += std::log(lum + 1e-6), ++n;
    }
  return n ? std::log2(0.18) - log_sum / double(n) / std::log(2.0) : 0.0;
}

std::uint8_t srgb_code(float display_linear) {
  const float v = std::isnan(display_linear) ? 0.0f : std::clamp(display_linear, 0.0f, 1.0f);
  return std::uint8_t(std::lround(255.0f * std::clamp(linear_to_srgb(v), 0.0f, 1.0f)));
}

std::vector<std::uint8_t> preview_pixels(ConstImageView img, const PreviewOptions& options) {
  const double scale =
      std::exp2(options.exposure_stops ? *options.exposure_stops : auto_exposure_stops(img));
  std::vector<std::uint8_t> px(std::size_t(img.width) * img.height * 3);
  for (int y = 0; y < img.height; ++y)
    for (int x = 0; x < img.width; ++x)
      for (int c = 0; c < 3; ++c) {
        const float v = float(img.pixel(x, y)[c] * scale);
        // Infinity shows white; negatives (lossy probes) and NaN black.
        const float display = std::isinf(v) ? (v > 0 ? 1.0f : 0.0f)
                              : v > 0.0f    ? v / (1.0f + v)
                                            : 0.0f;
        px[(std::size_t(y) * img.width + x) * 3 + c] = srgb_code(display);
      }
  return px;
}

namespace {
void write_png_u8(const fs::path& path, int width, int height, int channels,
                  std::span<const std::uint8_t> bytes) {
  if (width <= 0 || height <= 0 ||
      bytes.size() != std::size_t(width) * std::size_t(height) * std::size_t(channels))
    throw std::invalid_argument("write_png: " + std::to_string(bytes.size()) + " bytes for a " +
                                std::to_string(width) + "x" + std::to_string(height) + "x" +
                                std::to_string(channels) + " image");
  OIIO::ImageSpec spec(width, height, channels, OIIO::TypeDesc::UINT8);
  spec.attribute("oiio:ColorSpace", "sRGB");
  write_atomically(path, spec, bytes.data(), OIIO::TypeDesc::UINT8, channels * std::ptrdiff_t(width));
}
}  // namespace

void write_png_rgb(const fs::path& path, int width, int height, std::span<const std::uint8_t> rgb) {
  write_png_u8(path, width, height, 3, rgb);
}

void write_png_rgba(const fs::path& path, int width, int height, std::span<const std::uint8_t> rgba) {
  write_png_u8(path, width, height, 4, rgba);
}

void write_png_preview(const fs::path& path, ConstImageView img, const PreviewOptions& options) {
  write_png_rgb(path, img.width, img.height, preview_pixels(img, options));
}

}  // namespace arlight
