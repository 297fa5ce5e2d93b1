#include "arlight/protocol/wire.hpp"

#include <Imath/half.h>
#if !ARLIGHT_NO_ZSTD
#include <zstd.h>
#endif

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstring>
#include <stdexcept>

namespace arlight::wire {

const char* error_code_name(ErrorCode code) {
  static constexpr const char* kNames[] = {"Unknown",  "Unauthorized",    "BadMessage",
                                           "TooLarge", "OutOfOrder",      "Unsupported",
                                           "Busy",     "SessionNotFound", "Internal",
                                           "Timeout",  "Moved"};
  const auto i = std::size_t(code);
  return i < std::size(kNames) ? kNames[i] : "Unknown";
}

const char* fault_name(Fault f) {
  switch (f) {
    case Fault::NotArlight:
      return "NotArlight";
    case Fault::Malformed:
      return "Malformed";
    case Fault::UnknownMessage:
      return "UnknownMessage";
    case Fault::OutOfRange:
      return "OutOfRange";
    case Fault::WrongSize:
      return "WrongSize";
    case Fault::OverLimit:
      return "OverLimit";
    case Fault::Missing:
      return "Missing";
  }
  return "?";
}

namespace {
std::string describe(const std::string& message, const std::string& field,
                     const std::string& detail) {
  if (message.empty() && field.empty()) return detail;
  if (field.empty()) return message + ": " + detail;
  return (message.empty() ? field : message + "." + field) + ": " + detail;
}
}  // namespace

DecodeError::DecodeError(Fault fault, std::string message, std::string field,
                         const std::string& detail)
    : InputError(describe(message, field, detail)),
      fault_(fault),
      message_(std::move(message)),
      field_(std::move(field)) {}

ErrorCode DecodeError::code() const {
  switch (fault_) {
    case Fault::OverLimit:
      return ErrorCode::TooLarge;
    // An enum value this version does not know: a newer peer, or a feature not offered.
    case Fault::OutOfRange:
      return field_ == "format" || field_ == "projection" || field_ == "coding"
                 ? ErrorCode::Unsupported
                 : ErrorCode::BadMessage;
    default:
      return ErrorCode::BadMessage;
  }
}

std::array<std::uint8_t, kHeaderBytes> frame_header(std::size_t n) {
  return {std::uint8_t(n), std::uint8_t(n >> 8), std::uint8_t(n >> 16), std::uint8_t(n >> 24)};
}

std::vector<std::uint8_t> frame(std::span<const std::uint8_t> envelope) {
  const auto header = frame_header(envelope.size());
  std::vector<std::uint8_t> out(kHeaderBytes + envelope.size());
  std::copy(header.begin(), header.end(), out.begin());
  std::copy(envelope.begin(), envelope.end(), out.begin() + kHeaderBytes);
  return out;
}

std::uint32_t read_header(std::span<const std::uint8_t, kHeaderBytes> header,
                          std::uint32_t max_message_bytes) {
  const std::uint32_t n = std::uint32_t(header[0]) | std::uint32_t(header[1]) << 8 |
                          std::uint32_t(header[2]) << 16 | std::uint32_t(header[3]) << 24;
  if (n == 0) throw DecodeError(Fault::Malformed, "", "", "empty message (length 0)");
  if (n > max_message_bytes)
    throw DecodeError(Fault::OverLimit, "", "",
                      "message of " + std::to_string(n) + " bytes is over the limit of " +
                          std::to_string(max_message_bytes));
  return n;
}

bool has_capability(const std::vector<std::string>& capabilities, std::string_view name) {
  return std::find(capabilities.begin(), capabilities.end(), name) != capabilities.end();
}

TileCoding choose_tile_coding(const std::vector<std::string>& capabilities) {
  const auto has = [&](const char* name) { return has_capability(capabilities, name); };
  if (has(kCapabilityTilesZstdPlanar)) return TileCoding::ZstdPlanar;
  const bool zstd = has(kCapabilityTilesZstd);
  if (!zstd && has(kCapabilityTilesPlanar)) return TileCoding::Planar;
  return has(kCapabilityTilesHalf) && !zstd ? TileCoding::Half : TileCoding::ZstdHalf;
}

namespace {

bool planar(TileCoding coding) {
  return coding == TileCoding::Planar || coding == TileCoding::ZstdPlanar;
}

// Planar: each channel's low bytes, then its high bytes, then every byte as its difference
// from the one before plus 128 (OpenEXR's ZIP predictor): a smooth map's bytes become runs
// near 128 that deflate and zstd pack a third smaller than interleaved halves (bench_tiles.cpp).
std::vector<std::uint8_t> to_planes(const std::vector<std::uint8_t>& half) {
  const std::size_t n = half.size() / 6;
  std::vector<std::uint8_t> out(half.size());
  std::size_t o = 0;
  for (std::size_t c = 0; c < 3; ++c)
    for (std::size_t byte = 0; byte < 2; ++byte)
      for (std::size_t i = 0; i < n; ++i) out[o++] = half[2 * (3 * i + c) + byte];
  for (std::size_t i = out.size(); i-- > 1;) out[i] = std::uint8_t(out[i] - out[i - 1] + 128);
  return out;
}

std::vector<std::uint8_t> from_planes(std::vector<std::uint8_t> planes) {
  for (std::size_t i = 1; i < planes.size(); ++i)
    planes[i] = std::uint8_t(planes[i] + planes[i - 1] - 128);
  const std::size_t n = planes.size() / 6;
  std::vector<std::uint8_t> half(planes.size());
  std::size_t o = 0;
  for (std::size_t c = 0; c < 3; ++c)
    for (std::size_t byte = 0; byte < 2; ++byte)
      for (std::size_t i = 0; i < n; ++i) half[2 * (3 * i + c) + byte] = planes[o++];
  return half;
}

}  // namespace

std::vector<std::uint8_t> encode_half_rgb(const float* rgb, std::size_t pixels, TileCoding coding) {
  std::vector<std::uint8_t> half(pixels * 6);
  for (std::size_t i = 0; i < pixels * 3; ++i) {
    const std::uint16_t bits = Imath::half(rgb[i]).bits();
    half[2 * i] = std::uint8_t(bits & 0xff), half[2 * i + 1] = std::uint8_t(bits >> 8);
  }
  if (planar(coding)) half = to_planes(half);
  if (coding == TileCoding::Half || coding == TileCoding::Planar) return half;
#if ARLIGHT_NO_ZSTD
  throw std::logic_error("this build has no zstd: send TileCoding::Half");
#else
  std::vector<std::uint8_t> out(ZSTD_compressBound(half.size()));
  const std::size_t n = ZSTD_compress(out.data(), out.size(), half.data(), half.size(), 3);
  out.resize(ZSTD_isError(n) ? 0 : n);
  return out;
#endif
}

std::optional<std::vector<float>> decode_half_rgb(std::span<const std::uint8_t> data,
                                                  std::size_t pixels, TileCoding coding,
                                                  std::string& why) {
  std::vector<std::uint8_t> unpacked;
  std::span<const std::uint8_t> half = data;
  if (coding == TileCoding::ZstdHalf || coding == TileCoding::ZstdPlanar) {
#if ARLIGHT_NO_ZSTD
    why = "tile data is zstd, which this build cannot read (its Hello did not accept it)";
    return std::nullopt;
#else
    const unsigned long long size = ZSTD_getFrameContentSize(data.data(), data.size());
    if (size == ZSTD_CONTENTSIZE_ERROR || size == ZSTD_CONTENTSIZE_UNKNOWN) {
      why = "tile data is not a zstd frame with a known size";
      return std::nullopt;
    }
    if (size != pixels * 6) {
      why = "tile data holds " + std::to_string(size) + " bytes, expected " +
            std::to_string(pixels * 6);
      return std::nullopt;
    }
    unpacked.resize(pixels * 6);
    const std::size_t n =
        ZSTD_decompress(unpacked.data(), unpacked.size(), data.data(), data.size());
    if (ZSTD_isError(n) || n != unpacked.size()) {
      why = "tile data does not decompress";
      return std::nullopt;
    }
    half = unpacked;
#endif
  } else if (data.size() != pixels * 6) {
    why = "tile data holds " + std::to_string(data.size()) + " bytes, expected " +
          std::to_string(pixels * 6);
    return std::nullopt;
  }
  if (planar(coding)) {
    unpacked = from_planes(std::vector<std::uint8_t>(half.begin(), half.end()));
    half = unpacked;
  }
  std::vector<float> out(pixels * 3);
  for (std::size_t i = 0; i < out.size(); ++i) {
    Imath::half h;
    h.setBits(std::uint16_t(half[2 * i] | half[2 * i + 1] << 8));
    out[i] = float(h);
    if (!std::isfinite(out[i])) {
      why = "tile data holds a non-finite value";
      return std::nullopt;
    }
  }
  return out;
}

void parse_endpoint(const std::string& text, std::string& host, std::uint16_t& port) {
  const auto colon = text.rfind(':');
  if (colon == std::string::npos || colon == 0 || colon + 1 == text.size())
    throw InputError("'" + text + "': expected HOST:PORT");
  const std::string p = text.substr(colon + 1);
  if (p.size() > 5 ||
      !std::all_of(p.begin(), p.end(), [](unsigned char ch) { return std::isdigit(ch) != 0; }) ||
      std::stoi(p) > 65535)
    throw InputError("'" + text + "': the port must be a number 0-65535");
  host = text.substr(0, colon);
  port = std::uint16_t(std::stoi(p));
}

}  // namespace arlight::wire
