#include "arlight/wire.hpp"

#include <Imath/half.h>
#include <zstd.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstring>

#include "arlight/error.hpp"

namespace arlight::wire {

std::optional<std::uint32_t> read_header(std::span<const std::uint8_t, kHeaderBytes> header,
                                         std::uint32_t max_message_bytes, std::string& why) {
  const std::uint32_t n = std::uint32_t(header[0]) | std::uint32_t(header[1]) << 8 |
                          std::uint32_t(header[2]) << 16 | std::uint32_t(header[3]) << 24;
  if (n == 0) {
    why = "empty message (length 0)";
    return std::nullopt;
  }
  if (n > max_message_bytes) {
    why = "message of " + std::to_string(n) + " bytes is over the limit of " +
          std::to_string(max_message_bytes);
    return std::nullopt;
  }
  return n;
}

std::vector<std::uint8_t> frame_message(const flatbuffers::FlatBufferBuilder& builder) {
  const std::uint32_t n = builder.GetSize();
  std::vector<std::uint8_t> out(kHeaderBytes + n);
  for (int i = 0; i < 4; ++i) out[std::size_t(i)] = std::uint8_t(n >> (8 * i));
  std::memcpy(out.data() + kHeaderBytes, builder.GetBufferPointer(), n);
  return out;
}

const Envelope* verify_envelope(std::span<const std::uint8_t> payload, std::string& why) {
  if (payload.size() < 8 || !EnvelopeBufferHasIdentifier(payload.data())) {
    why = "not an arlight message (no ARL1 identifier)";
    return nullptr;
  }
  flatbuffers::Verifier verifier(payload.data(), payload.size(), /*max_depth=*/16,
                                 /*max_tables=*/100000);
  if (!VerifyEnvelopeBuffer(verifier)) {
    why = "message failed the FlatBuffers verifier (truncated or malformed)";
    return nullptr;
  }
  const Envelope* e = GetEnvelope(payload.data());
  if (e->message_type() == Message::NONE || e->message() == nullptr) {
    why = "envelope carries no message";
    return nullptr;
  }
  return e;
}

namespace {

template <class T>
std::vector<std::uint8_t> finish(flatbuffers::FlatBufferBuilder& b, flatbuffers::Offset<T> m) {
  b.Finish(CreateEnvelope(b, MessageTraits<T>::enum_value, m.Union()), EnvelopeIdentifier());
  return frame_message(b);
}

}  // namespace

std::vector<std::uint8_t> make_error(ErrorCode code, const std::string& message) {
  flatbuffers::FlatBufferBuilder b(256);
  return finish(b, CreateError(b, code, b.CreateString(message)));
}

std::vector<std::uint8_t> make_pong(std::uint64_t nonce) {
  flatbuffers::FlatBufferBuilder b(64);
  return finish(b, CreatePong(b, nonce));
}

std::vector<std::uint8_t> make_ping(std::uint64_t nonce) {
  flatbuffers::FlatBufferBuilder b(64);
  return finish(b, CreatePing(b, nonce));
}

std::vector<std::uint8_t> make_bye() {
  flatbuffers::FlatBufferBuilder b(64);
  return finish(b, CreateBye(b));
}

std::vector<std::uint8_t> encode_half_rgb(const float* rgb, std::size_t pixels) {
  std::vector<std::uint16_t> half(pixels * 3);
  for (std::size_t i = 0; i < half.size(); ++i) half[i] = Imath::half(rgb[i]).bits();
  std::vector<std::uint8_t> out(ZSTD_compressBound(half.size() * 2));
  const std::size_t n = ZSTD_compress(out.data(), out.size(), half.data(), half.size() * 2, 3);
  out.resize(ZSTD_isError(n) ? 0 : n);
  return out;
}

std::optional<std::vector<float>> decode_half_rgb(std::span<const std::uint8_t> data,
                                                  std::size_t pixels, std::string& why) {
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
  std::vector<std::uint16_t> half(pixels * 3);
  const std::size_t n = ZSTD_decompress(half.data(), half.size() * 2, data.data(), data.size());
  if (ZSTD_isError(n) || n != half.size() * 2) {
    why = "tile data does not decompress";
    return std::nullopt;
  }
  std::vector<float> out(half.size());
  for (std::size_t i = 0; i < half.size(); ++i) {
    Imath::half h;
    h.setBits(half[i]);
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

const char* message_name(Message type) { return EnumNameMessage(type); }

}  // namespace arlight::wire
