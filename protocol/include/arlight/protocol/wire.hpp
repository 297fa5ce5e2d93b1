// The wire protocol's typed codec (protocol/PROTOCOL.md, schema protocol/arlight.fbs): a plain
// struct per message, `encode` to one FlatBuffers Envelope and `decode` back. Decoding checks
// everything before anything is used: the identifier, the FlatBuffers verifier, the union tag,
// every enum, every vector's size and every length against the limits; a bad buffer throws a
// DecodeError naming the message and the field. No other folder sees FlatBuffers.
//
// Transports frame Envelopes: over TCP and TLS as a 4-byte little-endian length then the
// Envelope (frame(), read_header()); over WebSocket one binary message each (MessageStream).
#pragma once

#include <array>
#include <bit>
#include <cstdint>
#include <glm/gtc/quaternion.hpp>
#include <glm/vec3.hpp>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include "arlight/common/camera.hpp"
#include "arlight/common/error.hpp"
#include "arlight/common/frame.hpp"
#include "arlight/common/geo.hpp"
#include "arlight/common/projection.hpp"
#include "arlight/common/sh.hpp"
#include "arlight/common/specular_lights.hpp"

namespace arlight::wire {

inline constexpr std::uint32_t kProtocolVersion = 1;
inline constexpr std::size_t kHeaderBytes = 4;
// Longest text field (names, ids, tokens, reasons): anything longer is not from a real peer.
inline constexpr std::size_t kMaxTextBytes = 4096;
inline constexpr std::size_t kMaxCalibrationFrames = 16;
// LightingUpdate.light_error when nothing is known yet (the capture's LightUncertainty::kMaxError),
// and the largest light_error_zones.
inline constexpr float kLightErrorUnknown = 10.0f;
inline constexpr std::uint8_t kMaxLightErrorZones = 32;

struct WireLimits {
  std::uint32_t max_message_bytes = 16u << 20;  // a 4K JPEG at top quality is ~5 MiB
  std::uint32_t max_frame_pixels = 4096u * 4096u;
  std::uint32_t max_map_size = 1024;  // --size N of a map set
  std::uint32_t max_maps = 16;        // shininess values per map set
  bool operator==(const WireLimits&) const = default;
};

// The schema's enums, values as on the wire.
enum class ErrorCode : std::uint16_t {
  Unknown = 0,
  Unauthorized,     // no or wrong token for the device
  BadMessage,       // failed the verifier, or a field out of range
  TooLarge,         // over a size limit (message, frame pixels)
  OutOfOrder,       // e.g. a frame before Hello/CameraIntrinsics, a second Hello
  Unsupported,      // protocol version, pixel format, projection or method not offered
  Busy,             // session limit reached, or a client that does not read
  SessionNotFound,  // resume of an unknown session id
  Internal,
  Timeout,  // no Hello in time after connecting, or no message for the idle timeout
  Moved     // the session is live on another arlightd: Error.address says where (issue 49 §2)
};
const char* error_code_name(ErrorCode code);  // "Unauthorized", ...

enum class PixelFormat : std::uint8_t { Jpeg = 0, Rgb8 };

// IMU sample in camera coordinates (RECORDING.md): gyro rad/s, accelerometer m/s^2.
struct ImuSample {
  double t = 0;
  glm::vec3 gyro{0.0f}, accel{0.0f};
  bool operator==(const ImuSample&) const = default;
};

// ---- client -> server ----

struct Hello {
  std::uint32_t protocol_version = kProtocolVersion;
  std::string client_name;  // free text, e.g. "arlight-replay 0.1"
  std::string device_id;    // keys the token and the camera response curve
  std::string auth_token;
  std::vector<std::string> capabilities;  // e.g. "maps", "jpeg"
  std::string resume_session;             // a session id from an earlier Welcome
  // A live session to watch (PROTOCOL.md item 1): its LightingUpdates and map sets, no frames.
  std::string watch_session;
  // A live session to capture into from another device (PROTOCOL.md, contributors): its frames
  // are registered with the session's map, then merged into it.
  std::string join_session;
  bool operator==(const Hello&) const = default;
};

struct CameraIntrinsicsMessage {
  CameraIntrinsics camera;  // distortion: up to 5 terms on the wire, the rest 0
  bool operator==(const CameraIntrinsicsMessage& o) const;
};

struct CameraFrame {
  std::uint64_t sequence = 0;  // increasing per session; LightingUpdate echoes it
  FrameInfo info;
  bool has_orientation = true;  // false: the sender had none (the capture refuses the frame)
  PixelFormat format = PixelFormat::Jpeg;
  std::uint32_t width = 0, height = 0;  // must equal the intrinsics
  std::vector<std::uint8_t> data;       // JPEG bytes, or width*height*3 RGB bytes
  std::vector<ImuSample> imu;
  bool operator==(const CameraFrame& o) const;
};

struct CalibrationSet {  // one view at several exposures (response calibration)
  std::string method;    // "robertson" (default) or "debevec"
  std::vector<CameraFrame> frames;
  bool operator==(const CalibrationSet&) const = default;
};

// Which maps a RequestMaps asks for and a MapTile belongs to (arlight.fbs MapKind).
enum class MapKind : std::uint8_t { Phong = 0, Ggx = 1 };

struct RequestMaps {
  std::vector<float> shininess;  // e.g. 1, 10, 20, 40, 80, 160, 320, 1280
  std::uint32_t size = 0;        // --size N of arlight-maps; Ggx: level 0's face
  Projection projection = Projection::AngleMap;
  std::string method;  // "auto" when empty
  // Ggx: the GGX chain (shininess, projection and method unused), `levels` levels from face
  // `size` (0: down to face 16).
  MapKind kind = MapKind::Phong;
  std::uint8_t levels = 0;
  // Ggx: up to this many small, bright lights taken out of the chain's room (split_specular_
  // lights; at most kMaxSpecularLights), sent in MapSetComplete::lights. 0: the whole room.
  std::uint8_t specular_lights = 0;
  bool operator==(const RequestMaps&) const = default;
};

// A GGX chain request's level count: `levels` as asked, or (0) from `face` down to face 16 (or
// to face 1 from a smaller face). 0 for a face that is not a power of two, or `levels` that
// would go below one texel a face: a request arlightd refuses.
inline int ggx_level_count(std::uint32_t face, int levels) {
  if (face == 0 || (face & (face - 1)) != 0 || levels < 0) return 0;
  const int halvings = std::countr_zero(face);  // to face 1
  if (levels > 0) return levels - 1 <= halvings ? levels : 0;
  return halvings - (face > 16 ? 4 : halvings) + 1;
}

struct Ping {
  std::uint64_t nonce = 0;
  bool operator==(const Ping&) const = default;
};
struct Bye {
  bool operator==(const Bye&) const = default;
};

// ---- server -> client ----

struct Welcome {
  std::string session_id;
  std::string server_version;
  bool resumed = false;
  std::uint64_t frames_processed = 0;  // of the session so far (non-zero after a resume)
  std::optional<WireLimits> limits;    // what this server accepts
  std::vector<std::string> capabilities;  // e.g. kServerCapabilityLocation
  // The newest frame sequence the session holds: after a resume, send the frames after it again.
  std::uint64_t last_sequence = 0;
  bool operator==(const Welcome& o) const;
};

// A device's frames against the session's map (LightingUpdate.registration, issue 49 §1).
enum class Registration : std::uint8_t { Own = 0, Waiting = 1, Registered = 2 };

struct LightingUpdate {
  std::uint64_t frame_sequence = 0;  // the newest frame this reflects
  bool frame_used = false;           // false: that frame was skipped (see reason)
  std::string reason;
  ShCoeffs sh;                         // radiance SH; float precision on the wire
  glm::vec3 dominant_direction{0.0f};  // unit, world frame: where the strongest light comes from
  glm::vec3 dominant_colour{0.0f};     // its radiance
  float coverage = 0;                  // fraction of the sphere seen (measured)
  std::uint64_t frames_processed = 0, frames_dropped = 0;
  // Fraction of the sphere whose radiance in `sh` and the maps is estimated from what was seen
  // (the rest of 1 - coverage is black: the server does not fill).
  float estimated = 0;
  // The exposure x gain the server took that frame at, in the map's units: as the client
  // reported it, or as estimated from the frame's overlap with the map when the client said
  // exposure:unknown (what the client should tone-map the composite with). 0 for a frame
  // that was not used.
  double frame_exposure = 0;
  // The sun (PROTOCOL.md, location): Unknown until a Location arrives; towards it, world frame.
  // Confirmed: the captured map's brightest compact light is where the sun is, and
  // dominant_direction is the sun's direction.
  SunState sun_state = SunState::Unknown;
  glm::vec3 sun_direction{0.0f};
  // The frames the server needs now (PROTOCOL.md, frame advice): at most advised_width x
  // advised_height (the camera's size reduced by a power of two: what its map can hold) and
  // advised_fps a second (fewer once the frames agree with the map). 0: no advice.
  std::uint16_t advised_width = 0, advised_height = 0;
  float advised_fps = 0;
  // Frames up to this sequence are in the session's newest checkpoint: no longer worth keeping
  // for a fail-over (PROTOCOL.md, fail-over).
  std::uint64_t saved_sequence = 0;
  // The most bytes a frame should take to cross the client's uplink in 1/30 s, at the rate the
  // server measured its frames arriving at (PROTOCOL.md, frame advice). 0: no advice (no
  // measurement, or a link so fast that no frame is limited).
  std::uint32_t advised_frame_bytes = 0;
  // How far the light may be off (PROTOCOL.md, uncertainty): the expected relative irradiance
  // error (0.05: +-5 %; kLightErrorUnknown: nothing seen; 0: not stated), and per normal on
  // light_error_zones x 2 light_error_zones equal-area cells, in percent (255: >= 255 %).
  float light_error = 0;
  std::uint8_t light_error_zones = 0;
  std::vector<std::uint8_t> light_error_map;
  // The view that would cut light_error most: where to point the camera (unit, world frame),
  // and the expected cut; none when nothing is left to gain.
  std::optional<glm::vec3> next_view;
  float next_view_gain = 0;
  // A contributor's frames (Hello.join_session): whether its device is registered with the
  // session's map yet. Own: the session's own device.
  Registration registration = Registration::Own;
  bool operator==(const LightingUpdate& o) const;
};

// How a MapTile's texels are coded (arlight.fbs TileCoding).
enum class TileCoding : std::uint8_t { ZstdHalf = 0, Half = 1, ZstdPlanar = 2, Planar = 3 };

// Capabilities a Hello may name beside "maps" and "jpeg" (PROTOCOL.md, capabilities).
inline constexpr const char* kCapabilityTilesZstd = "tiles:zstd-half";  // accepts ZstdHalf tiles
inline constexpr const char* kCapabilityTilesHalf = "tiles:half";       // accepts Half tiles
// ... the same half floats as byte planes with OpenEXR's ZIP predictor (issue 36 §2: a third
// fewer bytes once compressed), zstd-compressed or (browsers: deflate) not.
inline constexpr const char* kCapabilityTilesZstdPlanar = "tiles:zstd-planar";
inline constexpr const char* kCapabilityTilesPlanar = "tiles:planar";
// The client cannot report exposure or gain (most browsers): the server treats its frames as
// taken at one locked exposure, whatever CameraFrame.exposure and gain say.
inline constexpr const char* kCapabilityExposureUnknown = "exposure:unknown";
// ... that one exposure: 1/60 s at gain 1, what a phone camera in a lit room locks to (any
// fixed value gives the same relative map). Such a client sends it in CameraFrame.exposure.
inline constexpr double kLockedExposureSeconds = 1.0 / 60.0;
// The client can take a frame at an exposure it is told (ExposureAdvice): only such clients
// are sent the advice.
inline constexpr const char* kCapabilityExposureAdvice = "exposure:advice";
// The client assembles a map set from the tiles that changed and an earlier set it holds
// (MapSetComplete.base_set, issue 36 §2): such clients are sent only what changed.
inline constexpr const char* kCapabilityMapDeltas = "maps:deltas";

// The coding the server sends a client with these capabilities: ZstdPlanar when it accepts it;
// ZstdHalf when it accepts that or names no coding at all (clients from before codings were
// negotiated); otherwise Planar when it accepts it, else Half.
TileCoding choose_tile_coding(const std::vector<std::string>& capabilities);
bool has_capability(const std::vector<std::string>& capabilities, std::string_view name);

struct MapTile {
  std::uint32_t map_set = 0;    // increases with every recomputation
  std::uint16_t map_index = 0;  // index into the requested shininess list
  float shininess = 0;
  Projection projection = Projection::AngleMap;
  std::uint32_t map_width = 0, map_height = 0;
  std::uint8_t level = 0;  // 0 full resolution; >0 a coarse preview 2^level smaller
  std::uint32_t x = 0, y = 0, width = 0, height = 0;  // tile rectangle at that level
  std::vector<std::uint8_t> data;                     // encode_half_rgb of width*height RGB texels
  TileCoding coding = TileCoding::ZstdHalf;           // of data
  // Ggx: map_index is the chain's level, `roughness` its perceptual roughness (shininess 0).
  MapKind kind = MapKind::Phong;
  float roughness = 0;
  bool operator==(const MapTile&) const = default;
};

struct MapSetComplete {
  std::uint32_t map_set = 0;
  std::uint16_t maps = 0;
  float seconds = 0, coverage = 0;
  std::uint64_t frames = 0;  // frames merged into the map this set was computed from
  // A set of only the tiles that changed since `base_set` (kCapabilityMapDeltas): the client
  // takes every other tile from that set; `tiles` is how many level-0 tiles this one sent, so a
  // client that missed one (a set resumed on a new connection mid-way) drops it. 0: whole.
  std::uint32_t base_set = 0, tiles = 0;
  // The lights taken out of a GGX chain asked for with specular_lights (the chain holds the rest).
  std::vector<SpecularLight> lights = {};
  bool operator==(const MapSetComplete&) const = default;
};

struct Progress {
  std::uint32_t map_set = 0, tiles_done = 0, tiles_total = 0;
  bool operator==(const Progress&) const = default;
};

struct Error {
  ErrorCode code = ErrorCode::Unknown;
  std::string message;
  // Moved: HOST:PORT of the arlightd that holds the session, on the same kind of port as the
  // one this connection came to (client port, or web port for a WebSocket); empty otherwise.
  std::string address;
  bool operator==(const Error&) const = default;
};

struct Pong {
  std::uint64_t nonce = 0;
  bool operator==(const Pong&) const = default;
};

// The answer to a CalibrationSet: the curve is stored for the device, or why not.
struct CalibrationResult {
  bool stored = false;
  std::string method;
  std::uint32_t frames = 0;
  std::string message;
  bool operator==(const CalibrationResult&) const = default;
};

// Take the next frame at `exposure` (exposure x gain, seconds at gain 1): frame
// `frame_sequence` had lights clipped that no frame has measured unclipped yet (issue 16 §4).
// exposure 0: no darker frame is needed any more.
struct ExposureAdvice {
  std::uint64_t frame_sequence = 0;
  double exposure = 0;
  float clipped = 0;  // fraction of that frame's pixels clipped and not yet measured
  bool operator==(const ExposureAdvice&) const = default;
};

// Where and when the client is (client -> server, to a server whose Welcome names
// kServerCapabilityLocation): the sun's place in the sky follows (dissertation §5.3.3).
struct Location {
  GeoLocation where;
  double utc_seconds = 0;         // Unix time at the client when sent
  bool north_referenced = false;  // the frames' world -Z is (compass) north
  double north_offset_deg = 0;    // that north's azimuth from true north, eastward
  bool operator==(const Location&) const = default;
};

// What a server's Welcome may name: it takes Location messages.
inline constexpr const char* kServerCapabilityLocation = "location";
// ... and RequestJoinToken (client -> server; PROTOCOL.md "Contributors").
inline constexpr const char* kServerCapabilityJoin = "join";

// The session's own device asks for a join token (issue 49 §1).
struct RequestJoinToken {
  bool operator==(const RequestJoinToken&) const = default;
};
// The answer (server -> client): another device joins `session_id` with Hello.join_session and
// `token` as its auth_token, within `expires_in_s` seconds and while the session's device is
// connected.
struct JoinToken {
  std::string session_id;
  std::string token;  // 32 hex characters
  float expires_in_s = 0;
  bool operator==(const JoinToken&) const = default;
};

// In the schema's union order.
using Message =
    std::variant<Hello, CameraIntrinsicsMessage, CameraFrame, CalibrationSet, RequestMaps, Ping,
                 Bye, Welcome, LightingUpdate, MapTile, MapSetComplete, Progress, Error, Pong,
                 CalibrationResult, ExposureAdvice, Location, RequestJoinToken, JoinToken>;

const char* message_name(const Message& m);  // "Hello", "CameraFrame", ...

// What was wrong with a buffer, by class.
enum class Fault {
  NotArlight,      // too short for an Envelope, or not the ARL1 identifier
  Malformed,       // failed the FlatBuffers verifier (truncated, bad offsets)
  UnknownMessage,  // no message, or a union tag this version does not know
  OutOfRange,      // an enum value or a number outside what the field allows
  WrongSize,       // a vector whose length does not fit the other fields
  OverLimit,       // a length over the limits (message, pixels, maps, text)
  Missing,         // a required field absent or empty
};
const char* fault_name(Fault f);

class DecodeError : public InputError {
 public:
  DecodeError(Fault fault, std::string message, std::string field, const std::string& detail);
  Fault fault() const { return fault_; }
  const std::string& message() const { return message_; }  // "CameraFrame"; empty: envelope
  const std::string& field() const { return field_; }      // "width", "sh", ...
  ErrorCode code() const;                                  // the ErrorCode a server answers with

 private:
  Fault fault_;
  std::string message_, field_;
};

// One Envelope holding the message (no length header).
std::vector<std::uint8_t> encode(const Message& message);
// The message in an Envelope, checked as the header says; DecodeError otherwise.
Message decode(std::span<const std::uint8_t> envelope, const WireLimits& limits = {});

// TCP/TLS framing: the 4-byte little-endian length, then the Envelope.
std::vector<std::uint8_t> frame(std::span<const std::uint8_t> envelope);
std::array<std::uint8_t, kHeaderBytes> frame_header(std::size_t envelope_bytes);
// The length a header announces; DecodeError (OverLimit, or Malformed for 0) otherwise.
std::uint32_t read_header(std::span<const std::uint8_t, kHeaderBytes> header,
                          std::uint32_t max_message_bytes);

// Map tiles travel as IEEE half floats (RGB, row-major, little-endian), interleaved or as byte
// planes (Planar codings), zstd-compressed or not.
std::vector<std::uint8_t> encode_half_rgb(const float* rgb, std::size_t pixels,
                                          TileCoding coding = TileCoding::ZstdHalf);
// Inverse of encode_half_rgb; std::nullopt (with why) when the data is not zstd (Zstd codings), is
// not exactly pixels * 6 bytes (after decompression), or holds non-finite values.
std::optional<std::vector<float>> decode_half_rgb(std::span<const std::uint8_t> data,
                                                  std::size_t pixels, TileCoding coding,
                                                  std::string& why);

// "host:port" (port 0-65535) -> host, port; InputError naming the text otherwise.
void parse_endpoint(const std::string& text, std::string& host, std::uint16_t& port);

}  // namespace arlight::wire
