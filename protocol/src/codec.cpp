// The typed codec: plain structs <-> FlatBuffers Envelopes (the only file that builds or reads
// the generated tables). Decoding refuses, with the message and field named, everything a
// peer could get wrong; what a field *means* (is the token right, is the map size served) stays
// with the daemon and the client.
#include <array>
#include <cmath>
#include <cstdint>
#include <glm/geometric.hpp>
#include <utility>
#include <vector>

#include "arlight/protocol/wire.hpp"
#include "arlight_generated.h"

namespace arlight::wire {

namespace {

using flatbuffers::FlatBufferBuilder;
using flatbuffers::Offset;

constexpr std::uint32_t kMaxDimension = 1u << 20;  // a side of a frame or intrinsics
constexpr std::uint32_t kMaxMapSide = 8192;        // a side of a map in a MapTile
constexpr std::uint32_t kMaxTileLevel = 12;
constexpr std::uint32_t kMaxMapIndex = 64;
constexpr std::size_t kMaxCapabilities = 64;
constexpr int kMaxShOrder = 128;
constexpr std::size_t kMaxDistortion = 5;

[[noreturn]] void refuse(Fault f, const char* message, const char* field,
                         const std::string& detail) {
  throw DecodeError(f, message, field, detail);
}

// FlatBuffers' verifier checks a vector's length word (4-byte aligned), not its elements: a
// [double] or [ImuSample] placed 4 bytes off would be read misaligned (undefined behaviour).
// The builder always aligns them, so such a message is malformed.
void require_aligned(const void* elements, std::size_t alignment, const char* message,
                     const char* field) {
  if (reinterpret_cast<std::uintptr_t>(elements) % alignment != 0)
    refuse(Fault::Malformed, message, field,
           "elements not aligned to " + std::to_string(alignment) + " bytes");
}

// ---- encode ----

Offset<flatbuffers::String> text(FlatBufferBuilder& b, const std::string& s) {
  return s.empty() ? 0 : b.CreateString(s);
}

Offset<fb::CameraFrame> build(FlatBufferBuilder& b, const CameraFrame& m) {
  const auto data = b.CreateVector(m.data);
  Offset<flatbuffers::Vector<const fb::ImuSample*>> imu = 0;
  if (!m.imu.empty()) {
    std::vector<fb::ImuSample> samples;
    samples.reserve(m.imu.size());
    for (const ImuSample& s : m.imu)
      samples.emplace_back(s.t, s.gyro.x, s.gyro.y, s.gyro.z, s.accel.x, s.accel.y, s.accel.z);
    imu = b.CreateVectorOfStructs(samples);
  }
  const fb::Quat q(m.info.orientation.w, m.info.orientation.x, m.info.orientation.y,
                   m.info.orientation.z);
  return fb::CreateCameraFrame(b, m.sequence, m.info.timestamp, m.info.exposure, m.info.gain,
                               m.has_orientation ? &q : nullptr, fb::PixelFormat(m.format), m.width,
                               m.height, data, imu);
}

Offset<void> build(FlatBufferBuilder& b, const Hello& m) {
  Offset<flatbuffers::Vector<Offset<flatbuffers::String>>> caps = 0;
  if (!m.capabilities.empty()) caps = b.CreateVectorOfStrings(m.capabilities);
  return fb::CreateHello(b, m.protocol_version, text(b, m.client_name), text(b, m.device_id),
                         text(b, m.auth_token), caps, text(b, m.resume_session),
                         text(b, m.watch_session), text(b, m.join_session))
      .Union();
}

Offset<void> build(FlatBufferBuilder& b, const CameraIntrinsicsMessage& m) {
  const CameraIntrinsics& k = m.camera;
  return fb::CreateCameraIntrinsics(
             b, std::uint32_t(k.width), std::uint32_t(k.height), k.fx, k.fy, k.cx, k.cy,
             b.CreateVector(std::vector<double>(k.distortion.begin(), k.distortion.end())))
      .Union();
}

Offset<void> build(FlatBufferBuilder& b, const CalibrationSet& m) {
  std::vector<Offset<fb::CameraFrame>> frames;
  for (const CameraFrame& f : m.frames) frames.push_back(build(b, f));
  return fb::CreateCalibrationSet(b, text(b, m.method), b.CreateVector(frames)).Union();
}

Offset<void> build(FlatBufferBuilder& b, const RequestMaps& m) {
  return fb::CreateRequestMaps(b, b.CreateVector(m.shininess), m.size,
                               fb::Projection(int(m.projection)), text(b, m.method),
                               fb::MapKind(int(m.kind)), m.levels, m.specular_lights)
      .Union();
}

Offset<void> build(FlatBufferBuilder& b, const Ping& m) {
  return fb::CreatePing(b, m.nonce).Union();
}
Offset<void> build(FlatBufferBuilder& b, const Bye&) { return fb::CreateBye(b).Union(); }
Offset<void> build(FlatBufferBuilder& b, const Pong& m) {
  return fb::CreatePong(b, m.nonce).Union();
}

Offset<void> build(FlatBufferBuilder& b, const Welcome& m) {
  Offset<fb::Limits> limits = 0;
  if (m.limits)
    limits = fb::CreateLimits(b, m.limits->max_message_bytes, m.limits->max_frame_pixels,
                              m.limits->max_map_size, m.limits->max_maps);
  Offset<flatbuffers::Vector<Offset<flatbuffers::String>>> caps = 0;
  if (!m.capabilities.empty()) caps = b.CreateVectorOfStrings(m.capabilities);
  return fb::CreateWelcome(b, text(b, m.session_id), text(b, m.server_version), m.resumed,
                           m.frames_processed, limits, caps, m.last_sequence)
      .Union();
}

Offset<void> build(FlatBufferBuilder& b, const LightingUpdate& m) {
  std::vector<float> flat;
  flat.reserve(m.sh.c.size() * 3);
  for (const glm::dvec3& c : m.sh.c) flat.insert(flat.end(), {float(c.x), float(c.y), float(c.z)});
  const fb::Vec3 d(m.dominant_direction.x, m.dominant_direction.y, m.dominant_direction.z);
  const fb::Vec3 c(m.dominant_colour.x, m.dominant_colour.y, m.dominant_colour.z);
  const fb::Vec3 sun(m.sun_direction.x, m.sun_direction.y, m.sun_direction.z);
  const glm::vec3 next = m.next_view.value_or(glm::vec3(0.0f));
  const fb::Vec3 view(next.x, next.y, next.z);
  return fb::CreateLightingUpdate(b, m.frame_sequence, m.frame_used, text(b, m.reason),
                                  std::uint8_t(m.sh.order), b.CreateVector(flat), &d, &c,
                                  m.coverage, m.frames_processed, m.frames_dropped, m.estimated,
                                  m.frame_exposure, std::uint8_t(m.sun_state),
                                  m.sun_state == SunState::Unknown ? nullptr : &sun,
                                  m.advised_width, m.advised_height, m.advised_fps,
                                  m.saved_sequence, m.advised_frame_bytes, m.light_error,
                                  m.light_error_zones,
                                  m.light_error_map.empty()
                                      ? 0
                                      : b.CreateVector(m.light_error_map),
                                  m.next_view ? &view : nullptr, m.next_view_gain,
                                  std::uint8_t(m.registration))
      .Union();
}

Offset<void> build(FlatBufferBuilder& b, const MapTile& m) {
  const auto data = b.CreateVector(m.data);
  return fb::CreateMapTile(b, m.map_set, m.map_index, m.shininess,
                           fb::Projection(int(m.projection)), m.map_width, m.map_height, m.level,
                           m.x, m.y, m.width, m.height, data, fb::TileCoding(int(m.coding)),
                           fb::MapKind(int(m.kind)), m.roughness)
      .Union();
}

Offset<void> build(FlatBufferBuilder& b, const MapSetComplete& m) {
  std::vector<fb::LightDisc> lights;
  for (const SpecularLight& l : m.lights)
    lights.emplace_back(fb::Vec3(l.direction.x, l.direction.y, l.direction.z),
                        fb::Vec3(l.power.x, l.power.y, l.power.z), l.radius);
  return fb::CreateMapSetComplete(b, m.map_set, m.maps, m.seconds, m.coverage, m.frames,
                                   m.base_set, m.tiles,
                                   lights.empty() ? 0 : b.CreateVectorOfStructs(lights))
      .Union();
}

Offset<void> build(FlatBufferBuilder& b, const Progress& m) {
  return fb::CreateProgress(b, m.map_set, m.tiles_done, m.tiles_total).Union();
}

Offset<void> build(FlatBufferBuilder& b, const Error& m) {
  return fb::CreateError(b, fb::ErrorCode(m.code), text(b, m.message), text(b, m.address))
      .Union();
}

Offset<void> build(FlatBufferBuilder& b, const ExposureAdvice& m) {
  return fb::CreateExposureAdvice(b, m.frame_sequence, m.exposure, m.clipped).Union();
}

Offset<void> build(FlatBufferBuilder& b, const RequestJoinToken&) {
  return fb::CreateRequestJoinToken(b).Union();
}

Offset<void> build(FlatBufferBuilder& b, const JoinToken& m) {
  return fb::CreateJoinToken(b, text(b, m.session_id), text(b, m.token), m.expires_in_s).Union();
}

Offset<void> build(FlatBufferBuilder& b, const Location& m) {
  return fb::CreateLocation(b, m.where.latitude_deg, m.where.longitude_deg, m.where.altitude_m,
                            m.utc_seconds, m.north_referenced, m.north_offset_deg)
      .Union();
}

Offset<void> build(FlatBufferBuilder& b, const CalibrationResult& m) {
  return fb::CreateCalibrationResult(b, m.stored, text(b, m.method), m.frames, text(b, m.message))
      .Union();
}

std::size_t size_hint(const Message& m) {
  if (const auto* f = std::get_if<CameraFrame>(&m)) return f->data.size() + 256;
  if (const auto* t = std::get_if<MapTile>(&m)) return t->data.size() + 256;
  if (const auto* s = std::get_if<CalibrationSet>(&m)) {
    std::size_t n = 256;
    for (const CameraFrame& f : s->frames) n += f.data.size() + 256;
    return n;
  }
  return 256;
}

// ---- decode ----

std::string text(const flatbuffers::String* s, const char* message, const char* field) {
  if (!s) return {};
  if (s->size() > kMaxTextBytes)
    refuse(Fault::OverLimit, message, field,
           std::to_string(s->size()) + " bytes of text, over the limit of " +
               std::to_string(kMaxTextBytes));
  return s->str();
}

Projection projection(fb::Projection p, const char* message) {
  const int v = int(p);
  if (v < int(Projection::AngleMap) || v > int(Projection::Cube))
    refuse(Fault::OutOfRange, message, "projection", "unknown projection " + std::to_string(v));
  return Projection(v);
}

MapKind map_kind(fb::MapKind k, const char* message) {
  const int v = int(k);
  if (v < int(MapKind::Phong) || v > int(MapKind::Ggx))
    refuse(Fault::OutOfRange, message, "kind", "unknown map kind " + std::to_string(v));
  return MapKind(v);
}

Hello read(const fb::Hello& m, const WireLimits&) {
  Hello h;
  h.protocol_version = m.protocol_version();
  h.client_name = text(m.client_name(), "Hello", "client_name");
  h.device_id = text(m.device_id(), "Hello", "device_id");
  h.auth_token = text(m.auth_token(), "Hello", "auth_token");
  h.resume_session = text(m.resume_session(), "Hello", "resume_session");
  h.watch_session = text(m.watch_session(), "Hello", "watch_session");
  h.join_session = text(m.join_session(), "Hello", "join_session");
  if (int(!h.resume_session.empty()) + int(!h.watch_session.empty()) +
          int(!h.join_session.empty()) > 1)
    refuse(Fault::OutOfRange, "Hello", h.join_session.empty() ? "watch_session" : "join_session",
           "a Hello resumes a session, watches one or joins one, only one of them");
  if (const auto* caps = m.capabilities()) {
    if (caps->size() > kMaxCapabilities)
      refuse(Fault::OverLimit, "Hello", "capabilities",
             std::to_string(caps->size()) + " entries, over the limit of " +
                 std::to_string(kMaxCapabilities));
    for (const auto* c : *caps) h.capabilities.push_back(text(c, "Hello", "capabilities"));
  }
  return h;
}

CameraIntrinsicsMessage read(const fb::CameraIntrinsics& m, const WireLimits& limits) {
  const char* name = "CameraIntrinsics";
  if (m.width() > kMaxDimension || m.height() > kMaxDimension)
    refuse(Fault::OutOfRange, name, "width",
           std::to_string(m.width()) + "x" + std::to_string(m.height()) + " is not a camera");
  if (std::uint64_t(m.width()) * m.height() > limits.max_frame_pixels)
    refuse(Fault::OverLimit, name, "width",
           std::to_string(m.width()) + "x" + std::to_string(m.height()) +
               " pixels, over the limit of " + std::to_string(limits.max_frame_pixels));
  CameraIntrinsicsMessage out;
  CameraIntrinsics& k = out.camera;
  k.width = int(m.width()), k.height = int(m.height());
  k.fx = m.fx(), k.fy = m.fy(), k.cx = m.cx(), k.cy = m.cy();
  if (const auto* d = m.distortion()) {
    if (d->size() > kMaxDistortion)
      refuse(Fault::WrongSize, name, "distortion",
             std::to_string(d->size()) + " terms; at most 5 (k1, k2, p1, p2, k3)");
    require_aligned(d->Data(), alignof(double), name, "distortion");
    for (flatbuffers::uoffset_t i = 0; i < d->size(); ++i) k.distortion[i] = d->Get(i);
  }
  return out;
}

CameraFrame read_frame(const fb::CameraFrame& m, const WireLimits& limits, const char* name) {
  CameraFrame f;
  f.sequence = m.sequence();
  f.info.timestamp = m.timestamp();
  f.info.exposure = m.exposure();
  f.info.gain = m.gain();
  if (const fb::Quat* q = m.orientation())
    f.info.orientation = glm::dquat(q->w(), q->x(), q->y(), q->z());
  else
    f.has_orientation = false, f.info.orientation = glm::dquat(0, 0, 0, 0);
  const int format = int(m.format());
  if (format != int(PixelFormat::Jpeg) && format != int(PixelFormat::Rgb8))
    refuse(Fault::OutOfRange, name, "format", "unknown pixel format " + std::to_string(format));
  f.format = PixelFormat(format);
  f.width = m.width(), f.height = m.height();
  const std::uint64_t pixels = std::uint64_t(f.width) * f.height;
  const std::string size = std::to_string(f.width) + "x" + std::to_string(f.height);
  if (pixels == 0) refuse(Fault::OutOfRange, name, "width", size + " pixels");
  if (pixels > limits.max_frame_pixels)
    refuse(Fault::OverLimit, name, "width",
           size + " pixels, over the limit of " + std::to_string(limits.max_frame_pixels));
  if (!m.data() || m.data()->size() == 0)
    refuse(Fault::Missing, name, "data",
           "no image data (frame " + std::to_string(f.sequence) + ")");
  if (f.format == PixelFormat::Rgb8 && m.data()->size() != pixels * 3)
    refuse(Fault::WrongSize, name, "data",
           "RGB8 data of " + std::to_string(m.data()->size()) + " bytes for " + size + " pixels");
  f.data.assign(m.data()->begin(), m.data()->end());
  if (const auto* imu = m.imu()) {
    require_aligned(imu->Data(), alignof(fb::ImuSample), name, "imu");
    f.imu.reserve(imu->size());
    for (const fb::ImuSample* s : *imu)
      f.imu.push_back({s->t(), {s->gx(), s->gy(), s->gz()}, {s->ax(), s->ay(), s->az()}});
  }
  return f;
}

CameraFrame read(const fb::CameraFrame& m, const WireLimits& limits) {
  return read_frame(m, limits, "CameraFrame");
}

CalibrationSet read(const fb::CalibrationSet& m, const WireLimits& limits) {
  CalibrationSet s;
  s.method = text(m.method(), "CalibrationSet", "method");
  if (const auto* frames = m.frames()) {
    if (frames->size() > kMaxCalibrationFrames)
      refuse(Fault::OverLimit, "CalibrationSet", "frames",
             std::to_string(frames->size()) + " frames, over the limit of " +
                 std::to_string(kMaxCalibrationFrames));
    for (const fb::CameraFrame* f : *frames)
      s.frames.push_back(read_frame(*f, limits, "CalibrationSet.frames"));
  }
  return s;
}

RequestMaps read(const fb::RequestMaps& m, const WireLimits& limits) {
  RequestMaps r;
  if (const auto* s = m.shininess()) {
    if (s->size() > limits.max_maps)
      refuse(Fault::OverLimit, "RequestMaps", "shininess",
             std::to_string(s->size()) + " maps, over the limit of " +
                 std::to_string(limits.max_maps));
    r.shininess.assign(s->begin(), s->end());
  }
  r.size = m.size();
  r.projection = projection(m.projection(), "RequestMaps");
  r.method = text(m.method(), "RequestMaps", "method");
  r.kind = map_kind(m.kind(), "RequestMaps");
  r.levels = m.levels();
  r.specular_lights = m.specular_lights();
  if (r.specular_lights > kMaxSpecularLights)
    refuse(Fault::OverLimit, "RequestMaps", "specular_lights",
           std::to_string(r.specular_lights) + " lights, over the " +
               std::to_string(kMaxSpecularLights) + " a shader takes");
  return r;
}

Ping read(const fb::Ping& m, const WireLimits&) { return {m.nonce()}; }
Bye read(const fb::Bye&, const WireLimits&) { return {}; }
Pong read(const fb::Pong& m, const WireLimits&) { return {m.nonce()}; }

Welcome read(const fb::Welcome& m, const WireLimits&) {
  Welcome w;
  w.session_id = text(m.session_id(), "Welcome", "session_id");
  w.server_version = text(m.server_version(), "Welcome", "server_version");
  w.resumed = m.resumed();
  w.frames_processed = m.frames_processed();
  w.last_sequence = m.last_sequence();
  if (const fb::Limits* l = m.limits())
    w.limits =
        WireLimits{l->max_message_bytes(), l->max_frame_pixels(), l->max_map_size(), l->max_maps()};
  if (const auto* caps = m.capabilities()) {
    if (caps->size() > kMaxCapabilities)
      refuse(Fault::OverLimit, "Welcome", "capabilities",
             std::to_string(caps->size()) + " entries, over the limit of " +
                 std::to_string(kMaxCapabilities));
    for (const auto* c : *caps) w.capabilities.push_back(text(c, "Welcome", "capabilities"));
  }
  return w;
}

LightingUpdate read(const fb::LightingUpdate& m, const WireLimits&) {
  LightingUpdate u;
  u.frame_sequence = m.frame_sequence();
  u.frame_used = m.frame_used();
  u.reason = text(m.reason(), "LightingUpdate", "reason");
  const int order = m.sh_order();
  if (order > kMaxShOrder)
    refuse(Fault::OutOfRange, "LightingUpdate", "sh_order",
           "order " + std::to_string(order) + " is over " + std::to_string(kMaxShOrder));
  const std::size_t expected = std::size_t(sh_count(order)) * 3;
  const std::size_t got = m.sh() ? m.sh()->size() : 0;
  if (got != expected)
    refuse(Fault::WrongSize, "LightingUpdate", "sh",
           std::to_string(got) + " values for order " + std::to_string(order) + " (expected " +
               std::to_string(expected) + ")");
  u.sh = ShCoeffs(order);
  for (std::size_t k = 0; k < u.sh.c.size(); ++k)
    u.sh.c[k] = glm::dvec3(m.sh()->Get(flatbuffers::uoffset_t(3 * k)),
                           m.sh()->Get(flatbuffers::uoffset_t(3 * k + 1)),
                           m.sh()->Get(flatbuffers::uoffset_t(3 * k + 2)));
  if (const fb::Vec3* d = m.dominant_direction()) u.dominant_direction = {d->x(), d->y(), d->z()};
  if (const fb::Vec3* c = m.dominant_color()) u.dominant_colour = {c->x(), c->y(), c->z()};
  u.coverage = m.coverage();
  u.frames_processed = m.frames_processed();
  u.frames_dropped = m.frames_dropped();
  u.estimated = m.estimated();
  u.frame_exposure = m.frame_exposure();
  if (m.sun_state() > std::uint8_t(SunState::Confirmed))
    refuse(Fault::OutOfRange, "LightingUpdate", "sun_state",
           std::to_string(m.sun_state()) + " is not a sun state (0..3)");
  u.sun_state = SunState(m.sun_state());
  if (u.sun_state != SunState::Unknown) {
    const fb::Vec3* sun = m.sun_direction();
    if (!sun)
      refuse(Fault::OutOfRange, "LightingUpdate", "sun_direction", "missing for a known sun state");
    u.sun_direction = {sun->x(), sun->y(), sun->z()};
    const float len = glm::length(u.sun_direction);
    if (!(std::abs(len - 1.0f) < 1e-3f))
      refuse(Fault::OutOfRange, "LightingUpdate", "sun_direction",
             "length " + std::to_string(len) + " is not a unit vector's");
  }
  u.advised_width = m.advised_width();
  u.advised_height = m.advised_height();
  u.advised_fps = m.advised_fps();
  u.saved_sequence = m.saved_sequence();
  u.advised_frame_bytes = m.advised_frame_bytes();
  u.light_error = m.light_error();
  if (!(u.light_error >= 0.0f && u.light_error <= kLightErrorUnknown))
    refuse(Fault::OutOfRange, "LightingUpdate", "light_error",
           std::to_string(u.light_error) + " is not in [0, " +
               std::to_string(int(kLightErrorUnknown)) + "]");
  u.light_error_zones = m.light_error_zones();
  if (u.light_error_zones > kMaxLightErrorZones)
    refuse(Fault::OutOfRange, "LightingUpdate", "light_error_zones",
           std::to_string(u.light_error_zones) + " is more than " +
               std::to_string(kMaxLightErrorZones));
  if (const auto* map = m.light_error_map()) u.light_error_map.assign(map->begin(), map->end());
  const std::size_t cells = 2 * std::size_t(u.light_error_zones) * u.light_error_zones;
  if (u.light_error_map.size() != cells)
    refuse(Fault::OutOfRange, "LightingUpdate", "light_error_map",
           std::to_string(u.light_error_map.size()) + " cells for " +
               std::to_string(u.light_error_zones) + " zones (" + std::to_string(cells) +
               " expected)");
  if (const fb::Vec3* view = m.next_view()) {
    u.next_view = glm::vec3(view->x(), view->y(), view->z());
    const float len = glm::length(*u.next_view);
    if (!(std::abs(len - 1.0f) < 1e-3f))
      refuse(Fault::OutOfRange, "LightingUpdate", "next_view",
             "length " + std::to_string(len) + " is not a unit vector's");
  }
  if (m.registration() > std::uint8_t(Registration::Registered))
    refuse(Fault::OutOfRange, "LightingUpdate", "registration",
           std::to_string(m.registration()) + " is not a registration state (0-2)");
  u.registration = Registration(m.registration());
  u.next_view_gain = m.next_view_gain();
  if (!(u.next_view_gain >= 0.0f && u.next_view_gain <= kLightErrorUnknown))
    refuse(Fault::OutOfRange, "LightingUpdate", "next_view_gain",
           std::to_string(u.next_view_gain) + " is not in [0, " +
               std::to_string(int(kLightErrorUnknown)) + "]");
  if ((u.advised_width == 0) != (u.advised_height == 0))
    refuse(Fault::OutOfRange, "LightingUpdate", "advised_width",
           std::to_string(u.advised_width) + "x" + std::to_string(u.advised_height) +
               " is not a frame size (both or neither must be 0)");
  if (!(u.advised_fps >= 0.0f && u.advised_fps <= 240.0f))
    refuse(Fault::OutOfRange, "LightingUpdate", "advised_fps",
           std::to_string(u.advised_fps) + " is not a frame rate in [0, 240]");
  if (!(u.frame_exposure >= 0.0 && u.frame_exposure < 1e6))
    refuse(Fault::OutOfRange, "LightingUpdate", "frame_exposure",
           std::to_string(u.frame_exposure) + " is not an exposure x gain in [0, 1e6)");
  if (!(u.coverage >= 0.0f && u.coverage <= 1.001f) ||
      !(u.estimated >= 0.0f && u.estimated <= 1.001f))
    refuse(Fault::OutOfRange, "LightingUpdate", "coverage",
           "coverage " + std::to_string(u.coverage) + " and estimated " +
               std::to_string(u.estimated) + " must be fractions in [0, 1]");
  return u;
}

MapTile read(const fb::MapTile& m, const WireLimits&) {
  const char* name = "MapTile";
  MapTile t;
  t.map_set = m.map_set();
  t.map_index = m.map_index();
  t.shininess = m.shininess();
  t.projection = projection(m.projection(), name);
  t.map_width = m.map_width(), t.map_height = m.map_height();
  t.level = m.level();
  t.x = m.x(), t.y = m.y(), t.width = m.width(), t.height = m.height();
  const int coding = int(m.coding());
  if (coding < int(TileCoding::ZstdHalf) || coding > int(TileCoding::Planar))
    refuse(Fault::OutOfRange, name, "coding", "unknown tile coding " + std::to_string(coding));
  t.coding = TileCoding(coding);
  t.kind = map_kind(m.kind(), name);
  t.roughness = m.roughness();
  if (t.kind == MapKind::Ggx && !(t.roughness >= 0.0f && t.roughness <= 1.0f))
    refuse(Fault::OutOfRange, name, "roughness",
           std::to_string(t.roughness) + " is not a roughness in [0, 1]");
  if (t.map_index >= kMaxMapIndex)
    refuse(Fault::OutOfRange, name, "map_index", std::to_string(t.map_index) + " is over 63");
  if (t.map_width == 0 || t.map_height == 0 || t.map_width > kMaxMapSide ||
      t.map_height > kMaxMapSide)
    refuse(Fault::OutOfRange, name, "map_width",
           std::to_string(t.map_width) + "x" + std::to_string(t.map_height) + " is not a map size");
  if (t.level > kMaxTileLevel)
    refuse(Fault::OutOfRange, name, "level", std::to_string(t.level) + " is over 12");
  // The map at that level: each level halves (rounding up, so any downsampling fits).
  const std::uint64_t w = (std::uint64_t(t.map_width) + (1u << t.level) - 1) >> t.level;
  const std::uint64_t h = (std::uint64_t(t.map_height) + (1u << t.level) - 1) >> t.level;
  if (t.width == 0 || t.height == 0 || std::uint64_t(t.x) + t.width > w ||
      std::uint64_t(t.y) + t.height > h)
    refuse(Fault::OutOfRange, name, "x",
           "tile " + std::to_string(t.width) + "x" + std::to_string(t.height) + " at (" +
               std::to_string(t.x) + ", " + std::to_string(t.y) + ") is outside the " +
               std::to_string(w) + "x" + std::to_string(h) + " map of level " +
               std::to_string(t.level));
  if (!m.data() || m.data()->size() == 0) refuse(Fault::Missing, name, "data", "no texels");
  t.data.assign(m.data()->begin(), m.data()->end());
  return t;
}

MapSetComplete read(const fb::MapSetComplete& m, const WireLimits&) {
  MapSetComplete c{m.map_set(), m.maps(),      m.seconds(), m.coverage(),
                   m.frames(),  m.base_set(), m.tiles(),    {}};
  if (const auto* lights = m.lights()) {
    if (lights->size() > std::size_t(kMaxSpecularLights))
      refuse(Fault::OverLimit, "MapSetComplete", "lights",
             std::to_string(lights->size()) + " lights, over " + std::to_string(kMaxSpecularLights));
    for (const fb::LightDisc* l : *lights) {
      const SpecularLight light{{l->direction().x(), l->direction().y(), l->direction().z()},
                                {l->power().x(), l->power().y(), l->power().z()},
                                l->radius()};
      if (const char* problem = specular_light_problem(light))
        refuse(Fault::OutOfRange, "MapSetComplete", "lights", std::string("a light: ") + problem);
      c.lights.push_back(light);
    }
  }
  return c;
}

Progress read(const fb::Progress& m, const WireLimits&) {
  return {m.map_set(), m.tiles_done(), m.tiles_total()};
}

Error read(const fb::Error& m, const WireLimits&) {
  const int code = int(m.code());
  if (code > int(ErrorCode::Moved))
    refuse(Fault::OutOfRange, "Error", "code", "unknown error code " + std::to_string(code));
  Error e{ErrorCode(code), text(m.message(), "Error", "message"),
          text(m.address(), "Error", "address")};
  // Moved names where to go, as HOST:PORT; nothing else names an address.
  if (e.code == ErrorCode::Moved) {
    std::string host;
    std::uint16_t port = 0;
    try {
      parse_endpoint(e.address, host, port);
    } catch (const InputError&) {
      port = 0;
    }
    if (host.empty() || port == 0)
      refuse(Fault::OutOfRange, "Error", "address",
             "Moved needs the HOST:PORT of the session's arlightd, not '" + e.address + "'");
  } else if (!e.address.empty()) {
    refuse(Fault::OutOfRange, "Error", "address", "only a Moved error names an address");
  }
  return e;
}

CalibrationResult read(const fb::CalibrationResult& m, const WireLimits&) {
  return {m.stored(), text(m.method(), "CalibrationResult", "method"), m.frames(),
          text(m.message(), "CalibrationResult", "message")};
}

ExposureAdvice read(const fb::ExposureAdvice& m, const WireLimits&) {
  const ExposureAdvice a{m.frame_sequence(), m.exposure(), m.clipped()};
  if (!(a.exposure >= 0.0 && a.exposure < 1e6))
    refuse(Fault::OutOfRange, "ExposureAdvice", "exposure",
           std::to_string(a.exposure) + " is not an exposure x gain in [0, 1e6)");
  if (!(a.clipped >= 0.0f && a.clipped <= 1.0f))
    refuse(Fault::OutOfRange, "ExposureAdvice", "clipped",
           std::to_string(a.clipped) + " is not a fraction in [0, 1]");
  return a;
}

RequestJoinToken read(const fb::RequestJoinToken&, const WireLimits&) { return {}; }

JoinToken read(const fb::JoinToken& m, const WireLimits&) {
  JoinToken t;
  t.session_id = text(m.session_id(), "JoinToken", "session_id");
  t.token = text(m.token(), "JoinToken", "token");
  if (t.token.empty() || t.token.size() > 64)
    refuse(Fault::OutOfRange, "JoinToken", "token",
           std::to_string(t.token.size()) + " characters (1 to 64)");
  t.expires_in_s = m.expires_in();
  if (!(t.expires_in_s > 0.0f && t.expires_in_s <= 86400.0f))
    refuse(Fault::OutOfRange, "JoinToken", "expires_in",
           std::to_string(t.expires_in_s) + " s is not in (0, 86400]");
  return t;
}

Location read(const fb::Location& m, const WireLimits&) {
  Location l;
  l.where = {m.latitude(), m.longitude(), m.altitude()};
  l.utc_seconds = m.utc_seconds();
  l.north_referenced = m.north_referenced();
  l.north_offset_deg = m.north_offset();
  if (const std::string e = geo_location_error(l.where); !e.empty())
    refuse(Fault::OutOfRange, "Location", "latitude", e);
  // Years 1000..3000 (what the sun's ephemeris is good for).
  if (!(l.utc_seconds > -30610224000.0 && l.utc_seconds < 32503680000.0))
    refuse(Fault::OutOfRange, "Location", "utc_seconds",
           std::to_string(l.utc_seconds) + " is not a time between the years 1000 and 3000");
  if (!(std::abs(l.north_offset_deg) <= 180.0))
    refuse(Fault::OutOfRange, "Location", "north_offset",
           std::to_string(l.north_offset_deg) + " is not an azimuth in [-180, 180]");
  return l;
}

// The generated table type of each alternative, in the union's order.
template <class T>
struct Table;
template <>
struct Table<Hello> {
  using type = fb::Hello;
};
template <>
struct Table<CameraIntrinsicsMessage> {
  using type = fb::CameraIntrinsics;
};
template <>
struct Table<CameraFrame> {
  using type = fb::CameraFrame;
};
template <>
struct Table<CalibrationSet> {
  using type = fb::CalibrationSet;
};
template <>
struct Table<RequestMaps> {
  using type = fb::RequestMaps;
};
template <>
struct Table<Ping> {
  using type = fb::Ping;
};
template <>
struct Table<Bye> {
  using type = fb::Bye;
};
template <>
struct Table<Welcome> {
  using type = fb::Welcome;
};
template <>
struct Table<LightingUpdate> {
  using type = fb::LightingUpdate;
};
template <>
struct Table<MapTile> {
  using type = fb::MapTile;
};
template <>
struct Table<MapSetComplete> {
  using type = fb::MapSetComplete;
};
template <>
struct Table<Progress> {
  using type = fb::Progress;
};
template <>
struct Table<Error> {
  using type = fb::Error;
};
template <>
struct Table<Pong> {
  using type = fb::Pong;
};
template <>
struct Table<CalibrationResult> {
  using type = fb::CalibrationResult;
};
template <>
struct Table<ExposureAdvice> {
  using type = fb::ExposureAdvice;
};
template <>
struct Table<Location> {
  using type = fb::Location;
};
template <>
struct Table<RequestJoinToken> {
  using type = fb::RequestJoinToken;
};
template <>
struct Table<JoinToken> {
  using type = fb::JoinToken;
};

// Each alternative's table must carry the union tag its position in Message implies.
template <std::size_t... I>
constexpr bool tags_match(std::index_sequence<I...>) {
  return ((fb::MessageTraits<
               typename Table<std::variant_alternative_t<I, Message>>::type>::enum_value ==
           fb::Message(I + 1)) &&
          ...);
}
static_assert(tags_match(std::make_index_sequence<std::variant_size_v<Message>>()),
              "wire::Message must list the schema's union members in order");

template <std::size_t I = 0>
Message read_any(const fb::Envelope& e, const WireLimits& limits) {
  if constexpr (I == std::variant_size_v<Message>) {
    refuse(Fault::UnknownMessage, "", "message",
           "union tag " + std::to_string(int(e.message_type())) + " is not a message of version " +
               std::to_string(kProtocolVersion));
  } else {
    using T = std::variant_alternative_t<I, Message>;
    using Fb = typename Table<T>::type;
    if (e.message_type() == fb::MessageTraits<Fb>::enum_value)
      return Message(std::in_place_index<I>, read(*static_cast<const Fb*>(e.message()), limits));
    return read_any<I + 1>(e, limits);
  }
}

}  // namespace

bool CameraIntrinsicsMessage::operator==(const CameraIntrinsicsMessage& o) const {
  const CameraIntrinsics &a = camera, &b = o.camera;
  return a.width == b.width && a.height == b.height && a.fx == b.fx && a.fy == b.fy &&
         a.cx == b.cx && a.cy == b.cy && a.distortion == b.distortion;
}

bool CameraFrame::operator==(const CameraFrame& o) const {
  return sequence == o.sequence && info.timestamp == o.info.timestamp &&
         info.exposure == o.info.exposure && info.gain == o.info.gain &&
         has_orientation == o.has_orientation &&
         (!has_orientation || info.orientation == o.info.orientation) && format == o.format &&
         width == o.width && height == o.height && data == o.data && imu == o.imu;
}

bool Welcome::operator==(const Welcome& o) const {
  return session_id == o.session_id && server_version == o.server_version && resumed == o.resumed &&
         frames_processed == o.frames_processed && limits == o.limits &&
         capabilities == o.capabilities && last_sequence == o.last_sequence;
}

bool LightingUpdate::operator==(const LightingUpdate& o) const {
  return frame_sequence == o.frame_sequence && frame_used == o.frame_used && reason == o.reason &&
         sh.order == o.sh.order && sh.c == o.sh.c && dominant_direction == o.dominant_direction &&
         dominant_colour == o.dominant_colour && coverage == o.coverage &&
         frames_processed == o.frames_processed && frames_dropped == o.frames_dropped &&
         estimated == o.estimated && frame_exposure == o.frame_exposure &&
         sun_state == o.sun_state && sun_direction == o.sun_direction &&
         advised_width == o.advised_width && advised_height == o.advised_height &&
         advised_fps == o.advised_fps && saved_sequence == o.saved_sequence &&
         advised_frame_bytes == o.advised_frame_bytes && light_error == o.light_error &&
         light_error_zones == o.light_error_zones && light_error_map == o.light_error_map &&
         next_view == o.next_view && next_view_gain == o.next_view_gain &&
         registration == o.registration;
}

const char* message_name(const Message& m) {
  return fb::EnumNameMessage(fb::Message(int(m.index()) + 1));
}

std::vector<std::uint8_t> encode(const Message& message) {
  FlatBufferBuilder b(size_hint(message));
  const Offset<void> body =
      std::visit([&](const auto& m) -> Offset<void> { return build(b, m).Union(); }, message);
  b.Finish(fb::CreateEnvelope(b, fb::Message(int(message.index()) + 1), body),
           fb::EnvelopeIdentifier());
  return {b.GetBufferPointer(), b.GetBufferPointer() + b.GetSize()};
}

Message decode(std::span<const std::uint8_t> payload, const WireLimits& limits) {
  // The verifier checks alignment relative to the buffer's start, so the start must be aligned
  // to the widest scalar (a double) for reads to be; copy a payload that is not.
  std::vector<std::uint8_t> aligned;
  if (reinterpret_cast<std::uintptr_t>(payload.data()) % alignof(double) != 0) {
    aligned.assign(payload.begin(), payload.end());
    payload = aligned;
  }
  if (payload.size() < 8 || !fb::EnvelopeBufferHasIdentifier(payload.data()))
    refuse(Fault::NotArlight, "", "", "not an arlight message (no ARL1 identifier)");
  if (payload.size() > limits.max_message_bytes)
    refuse(Fault::OverLimit, "", "",
           "message of " + std::to_string(payload.size()) + " bytes is over the limit of " +
               std::to_string(limits.max_message_bytes));
  flatbuffers::Verifier verifier(payload.data(), payload.size(), /*max_depth=*/16,
                                 /*max_tables=*/100000);
  if (!fb::VerifyEnvelopeBuffer(verifier))
    refuse(Fault::Malformed, "", "",
           "message failed the FlatBuffers verifier (truncated or malformed)");
  const fb::Envelope* e = fb::GetEnvelope(payload.data());
  if (e->message_type() == fb::Message::NONE || e->message() == nullptr)
    refuse(Fault::UnknownMessage, "", "message", "envelope carries no message");
  return read_any(*e, limits);
}

}  // namespace arlight::wire
