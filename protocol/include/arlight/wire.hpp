// The wire protocol's framing and checks (protocol/PROTOCOL.md, schema protocol/arlight.fbs):
// a message is a 4-byte little-endian length then one FlatBuffers Envelope. Everything that
// arrives is checked before use: the length against the limit before any allocation, then the
// whole buffer through the FlatBuffers verifier.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "arlight_generated.h"

namespace arlight::wire {

inline constexpr std::uint32_t kProtocolVersion = 1;
inline constexpr std::size_t kHeaderBytes = 4;

struct WireLimits {
  std::uint32_t max_message_bytes = 16u << 20;  // a 4K JPEG at top quality is ~5 MiB
  std::uint32_t max_frame_pixels = 4096u * 4096u;
  std::uint32_t max_map_size = 1024;  // --size N of a map set
  std::uint32_t max_maps = 16;        // shininess values per map set
};

// The length a header announces, or why it cannot be accepted (zero, over the limit).
std::optional<std::uint32_t> read_header(std::span<const std::uint8_t, kHeaderBytes> header,
                                         std::uint32_t max_message_bytes, std::string& why);

// Header + payload of a finished builder, ready to send.
std::vector<std::uint8_t> frame_message(const flatbuffers::FlatBufferBuilder& builder);

// The Envelope in `payload` if it passes the verifier, has the file identifier and carries a
// message; otherwise nullptr and why.
const Envelope* verify_envelope(std::span<const std::uint8_t> payload, std::string& why);

// Builders for the small messages (each returns a framed message).
std::vector<std::uint8_t> make_error(ErrorCode code, const std::string& message);
std::vector<std::uint8_t> make_pong(std::uint64_t nonce);
std::vector<std::uint8_t> make_ping(std::uint64_t nonce);
std::vector<std::uint8_t> make_bye();

// Map tiles travel as zstd-compressed IEEE half floats (RGB, row-major).
std::vector<std::uint8_t> encode_half_rgb(const float* rgb, std::size_t pixels);
// Inverse of encode_half_rgb; std::nullopt (with why) when the data is not zstd, does not
// decompress to exactly pixels * 6 bytes, or holds non-finite values.
std::optional<std::vector<float>> decode_half_rgb(std::span<const std::uint8_t> data,
                                                  std::size_t pixels, std::string& why);

const char* message_name(Message type);

// "host:port" (port 0-65535) -> host, port; InputError naming the text otherwise.
void parse_endpoint(const std::string& text, std::string& host, std::uint16_t& port);

}  // namespace arlight::wire
