// The page's API (web_client.hpp): the messages it sends and receives, tracking and the
// composite.
#include "web_client.hpp"

#include <GLES3/gl3.h>
#include <emscripten/bind.h>

#include <chrono>
#include <cmath>
#include <glm/gtc/quaternion.hpp>

#include "arlight/net/client_messages.hpp"
#include "arlight/protocol/wire.hpp"
#include "arlight/track/pose_math.hpp"
#include "js_messages.hpp"

namespace arlight::web {

val vector_to_js(const glm::vec3& v) {
  val a = val::array();
  for (int i = 0; i < 3; ++i) a.call<void>("push", v[i]);
  return a;
}

val pose_to_js(const Pose& p) {
  val position = val::array(), orientation = val::array();
  for (int i = 0; i < 3; ++i) position.call<void>("push", p.position[i]);
  for (const double v : {p.orientation.w, p.orientation.x, p.orientation.y, p.orientation.z})
    orientation.call<void>("push", v);
  val out = val::object();
  out.set("position", position);
  out.set("orientation", orientation);
  return out;
}

val WebClient::hello(const std::string& device, const std::string& token,
                     const std::string& resume, const std::string& join) {
  pacer_.forget_in_flight();  // a new connection: nothing sent before will be answered on it
  join_ = join;
  if (!join_.empty()) state_.expect_any_maps();  // a contributor takes the session's sets
  return bytes_to_js(wire::encode(
      wire::Hello{wire::kProtocolVersion,
                  "arlight-web 0.1",
                  device,
                  token,
                  {"maps", "jpeg", wire::kCapabilityTilesPlanar, wire::kCapabilityTilesHalf,
                   wire::kCapabilityExposureUnknown, wire::kCapabilityMapDeltas},
                  join_.empty() ? resume : std::string(),
                  "",
                  join_}));
}

val WebClient::request_join_token() const {
  const auto& welcome = state_.welcome();
  if (!join_.empty() || !welcome ||
      !wire::has_capability(welcome->capabilities, wire::kServerCapabilityJoin))
    return val::null();
  return bytes_to_js(wire::encode(wire::RequestJoinToken{}));
}

val WebClient::intrinsics() {
  return bytes_to_js(wire::encode(wire::CameraIntrinsicsMessage{camera_}));
}

val WebClient::frame_due(double timestamp) {
  constexpr double kCameraFps = 30.0;  // the jitter the pacer allows: half a frame of it
  const client::FramePacer::Decision d = pacer_.frame_due(timestamp, width_, height_, kCameraFps);
  val out = val::object();
  out.set("send", d.send);
  out.set("reduction", d.reduction);
  out.set("quality", d.quality);
  return out;
}

val WebClient::frame(double sequence, double timestamp, double qw, double qx, double qy, double qz,
                     const val& jpeg, int reduction, int quality) {
  if (!(reduction == 1 || reduction == 2 || reduction == 4 || reduction == 8)) reduction = 1;
  // exposure:unknown: the daemon locks the exposure anyway.
  const FrameInfo info{timestamp, wire::kLockedExposureSeconds, 1.0,
                       glm::normalize(glm::dquat(qw, qx, qy, qz))};
  const std::vector<std::uint8_t> bytes =
      emscripten::convertJSArrayToNumberVector<std::uint8_t>(jpeg);
  ++frames_sent_;
  pacer_.sent(timestamp, std::uint64_t(sequence));
  pacer_.encoded(bytes.size(), width_ / reduction, height_ / reduction, quality);
  unsaved_.keep(std::uint64_t(sequence), info, width_ / reduction, height_ / reduction, bytes,
                /*sent=*/true);
  return bytes_to_js(wire::encode(client::jpeg_frame(std::uint64_t(sequence), info,
                                                     width_ / reduction, height_ / reduction,
                                                     bytes)));
}

val WebClient::resend_frame(double timestamp) {
  const client::UnsavedFrames::Frame* f = unsaved_.next_waiting();
  if (!f || !pacer_.may_resend(timestamp)) return val::null();
  val bytes =
      bytes_to_js(wire::encode(client::jpeg_frame(f->sequence, f->info, f->width, f->height, f->jpeg)));
  pacer_.sent(timestamp, f->sequence);
  unsaved_.sent_next();
  return bytes;
}

val WebClient::request_maps() {
  if (!join_.empty()) return val::null();  // a contributor takes whatever sets the session has
  requested_ggx_ = render::needs_ggx_chain(draw_materials(), material_);
  const wire::RequestMaps request =
      // The page shades with the lights taken out of the chain (issue 51 §1): its renderer is
      // the native one.
      requested_ggx_ ? client::ggx_request(kGgxFace, 0, kMaxSpecularLights)
                     : client::map_request(kShininess, kMapSize, Projection::LatLong, "auto");
  state_.expect_maps(request);
  return bytes_to_js(wire::encode(request));
}

val WebClient::request_maps_if_changed() {
  if (!join_.empty() || render::needs_ggx_chain(draw_materials(), material_) == requested_ggx_)
    return val::null();
  return request_maps();
}

val WebClient::location(double latitude, double longitude, double altitude, double utc_seconds,
                        bool north_referenced) {
  const auto& welcome = state_.welcome();
  if (!join_.empty() || !welcome ||
      !wire::has_capability(welcome->capabilities, wire::kServerCapabilityLocation))
    return val::null();  // a contributor's place is the session's
  const GeoLocation where{latitude, longitude, std::isfinite(altitude) ? altitude : 0.0};
  if (const std::string e = geo_location_error(where); !e.empty())
    throw std::invalid_argument("location: " + e);
  return bytes_to_js(wire::encode(client::make_location(
      where, utc_seconds, north_referenced ? std::optional(0.0) : std::nullopt)));
}

std::string WebClient::receive(const val& bytes) {
  std::optional<wire::Message> decoded = message_from_js(bytes, last_error_);
  if (!decoded) return "refused: " + last_error_;
  wire::Message& m = *decoded;
  const std::string name = wire::message_name(m);
  if (const auto* u = std::get_if<wire::LightingUpdate>(&m)) {
    pacer_.advise(*u);
    unsaved_.saved(u->saved_sequence);
  }
  // The session resumed holds the frames up to last_sequence: those kept after it go again.
  if (const auto* w = std::get_if<wire::Welcome>(&m)) unsaved_.welcomed(w->last_sequence);
  const client::Lighting& lighting = state_.lighting();
  switch (state_.receive(std::move(m))) {
    case client::LightingState::Change::Error:
      last_error_ = state_.error()->first + ": " + state_.error()->second;
      break;
    case client::LightingState::Change::Update:
      if (!lighting.maps) renderer_.set_sh(*lighting.sh);
      break;
    case client::LightingState::Change::MapSet:
      if (state_.newest_set()->kind == wire::MapKind::Phong) {
        renderer_.set_maps(lighting.maps->shininess, lighting.maps->maps);
      } else {
        try {
          renderer_.set_ggx_chain(lighting.ggx->maps, lighting.ggx->roughness, lighting.ggx->lights);
        } catch (const std::invalid_argument& e) {
          last_error_ = std::string("GGX chain not used: ") + e.what();
        }
      }
      break;
    default:
      break;
  }
  return name;
}

val WebClient::marker_seen(double timestamp, double rx, double ry, double rz, double tx, double ty,
                           double tz, double qw, double qx, double qy, double qz) {
  const glm::dvec3 rvec(rx, ry, rz), tvec(tx, ty, tz);
  if (!std::isfinite(timestamp) || !std::isfinite(glm::length(rvec)) ||
      !std::isfinite(glm::length(tvec)) || !(tz > 0))
    throw std::invalid_argument("marker pose: not finite, or the marker behind the camera");
  const Pose raw = track::pose_from_opencv(rvec, tvec);
  const glm::dquat world_from_camera = glm::normalize(glm::dquat(qw, qx, qy, qz));
  const Pose smoothed = filter_.update(raw, timestamp);
  world_from_marker_.add(timestamp, world_from_camera, raw.orientation);
  // The frame's own measurement places the object (issue 36 §4: the page shows a tracked frame
  // with it; at the page's tracking rate, a few frames a second on a small machine, the filter's
  // smoothed pose trails the camera by up to 6 px), moved on by the filter's velocity for frames
  // shown without waiting for their own.
  placement_.tracked(timestamp, raw, filter_.velocity(), world_from_camera);
  ++tracked_frames_;
  val out = val::object();
  out.set("raw", pose_to_js(raw));
  out.set("smoothed", pose_to_js(smoothed));
  out.set("velocity", vector_to_js(glm::vec3(filter_.velocity())));
  return out;
}

unsigned WebClient::yuv_plane_texture(const std::string& layout, int plane) {
  return yuv().plane_texture(yuv_layout_named(layout), plane);
}

void WebClient::convert_yuv(const std::string& layout, const std::string& matrix, bool full_range) {
  yuv().convert(yuv_layout_named(layout), matrix, full_range, renderer_.camera_texture());
}

double WebClient::render(double timestamp, double qw, double qx, double qy, double qz) {
  const auto t0 = std::chrono::steady_clock::now();
  const glm::dquat world_from_camera = glm::normalize(glm::dquat(qw, qx, qy, qz));
  // On the marker: the newest tracked pose (the worker's result trails the shown frame), turned
  // by the rotation the orientation sensor measured since its frame and moved on by the pose
  // filter's velocity. After the marker is lost the object stays there, turned by the sensor
  // alone, until it is seen again. Before any marker: the preview.
  const auto on_marker = placement_.camera_in_marker(timestamp, world_from_camera);
  placed_on_marker_ = on_marker.has_value();
  const auto [camera_in_scene, world_from_scene] =
      on_marker ? std::pair{*on_marker, world_from_marker()}
                : client_app::preview_placement(world_from_camera, object_height_);
  renderer_.begin_frame();
  shadow_drawn_ = false;
  if (renderer_.lighting_source() != render::LightingSource::None) {
    last_camera_from_scene_ = track::view_matrix(camera_in_scene);
    last_world_from_scene_ = world_from_scene;
    renderer_.set_camera(camera_, *last_camera_from_scene_);
    renderer_.set_world_from_scene(world_from_scene);
    shadow_drawn_ = placement_.has_track();  // on the real floor: where a marker says it is
    renderer_.set_shadow(shadow_.settings(shadow_drawn_, state_.lighting()));
    renderer_.draw(mesh_, draw_materials(), material_, model_);
  }
  render::ToneMapping tone{render::ToneMode::CameraMatched, frame_exposure(), 1.0};
  tone.colour = colour_;
  renderer_.composite_in_place(tone);
  renderer_.present();
  ++frames_rendered_;
  // The frame-rate control needs the time the GPU took for the shadow: wait for it (the page
  // would wait for its next camera frame anyway) while there is a shadow to count.
  if (shadow_.target_fps() > 0 && shadow_drawn_) glFinish();
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

// The marker's rotation into the world: the estimate over its sightings, or the newest one's.
glm::dquat WebClient::world_from_marker() const {
  if (const auto w = world_from_marker_.world_from_marker()) return *w;
  return placement_.world_from_marker_of_track().value_or(glm::dquat(1.0, 0.0, 0.0, 0.0));
}

// The exposure arlightd took the newest frame at (the browser cannot say; its auto-exposure
// moves as the phone turns), in the map's units; the locked one until an update says.
double WebClient::frame_exposure() const {
  const double e = state_.lighting().frame_exposure;
  return e > 0 ? e : wire::kLockedExposureSeconds;
}

YuvFrame& WebClient::yuv() {
  if (!yuv_) yuv_.emplace(width_, height_, "/shaders");
  return *yuv_;
}

}  // namespace arlight::web
