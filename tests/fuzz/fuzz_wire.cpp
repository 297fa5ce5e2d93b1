// Fuzz target: what arrives from the network. The 4-byte frame header, the Envelope through the
// FlatBuffers verifier and the typed codec (wire::decode), and a MapTile's half-float texels.
// Anything may be refused with a DecodeError; what is accepted must encode again to bytes that
// decode to the same message (checked byte for byte, so NaN-safe).
#include <array>
#include <span>
#include <string>
#include <variant>

#include "arlight/protocol/wire.hpp"
#include "fuzz_support.hpp"

using namespace arlight;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const wire::WireLimits limits;
  const std::span<const std::uint8_t> input(data, size);
  if (size >= wire::kHeaderBytes) {
    try {
      wire::read_header(input.first<wire::kHeaderBytes>(), limits.max_message_bytes);
    } catch (const wire::DecodeError& e) {
      fuzz::refused(e);
    }
  }
  wire::Message message;
  try {
    message = wire::decode(input, limits);
  } catch (const wire::DecodeError& e) {
    fuzz::refused(e);
    return 0;
  }
  const std::vector<std::uint8_t> again = wire::encode(message);
  if (wire::encode(wire::decode(again, limits)) != again)
    fuzz::finding("a decoded message does not survive encode -> decode -> encode");
  if (const auto* tile = std::get_if<wire::MapTile>(&message)) {
    std::string why;
    const auto texels = wire::decode_half_rgb(
        tile->data, std::size_t(tile->width) * tile->height, tile->coding, why);
    if (!texels && why.empty()) fuzz::finding("decode_half_rgb refused a tile without saying why");
  }
  return 0;
}

FuzzSeeds arlight_fuzz_seeds() {
  FuzzSeeds seeds;
  wire::Hello hello;
  hello.client_name = "arlight-fuzz";
  hello.device_id = "phone-1";
  hello.auth_token = "token-0123456789";
  hello.capabilities = {"maps", "jpeg", wire::kCapabilityTilesZstd};
  seeds.push_back(wire::encode(hello));
  wire::CameraIntrinsicsMessage intrinsics;
  intrinsics.camera = CameraIntrinsics::from_fov(64, 48, 60);
  seeds.push_back(wire::encode(intrinsics));
  wire::CameraFrame frame;
  frame.sequence = 7;
  frame.info.exposure = 1.0 / 60;
  frame.format = wire::PixelFormat::Rgb8;
  frame.width = 4, frame.height = 2;
  frame.data.assign(4 * 2 * 3, 128);
  frame.imu = {{0.01, {0.1f, 0, 0}, {0, 9.81f, 0}}};
  seeds.push_back(wire::encode(frame));
  wire::RequestMaps request;
  request.shininess = {1, 10, 80};
  request.size = 64;
  seeds.push_back(wire::encode(request));
  wire::LightingUpdate update;
  update.frame_sequence = 7;
  update.frame_used = true;
  update.sh = ShCoeffs(3);
  for (auto& c : update.sh.c) c = glm::dvec3(0.5);
  update.coverage = 0.25f;
  seeds.push_back(wire::encode(update));
  for (wire::TileCoding coding : {wire::TileCoding::ZstdHalf, wire::TileCoding::Half}) {
    wire::MapTile tile;
    tile.map_width = tile.map_height = 8;
    tile.width = tile.height = 4;
    const std::array<float, 48> rgb{0.5f, 1.0f, 2.0f};
    tile.data = wire::encode_half_rgb(rgb.data(), 16, coding);
    tile.coding = coding;
    seeds.push_back(wire::encode(tile));
  }
  wire::Error error;
  error.message = "bad message";
  seeds.push_back(wire::encode(error));
  seeds.push_back(wire::encode(wire::Ping{42}));
  seeds.push_back(wire::encode(wire::Bye{}));
  return seeds;
}
