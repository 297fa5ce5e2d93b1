// The browser client's C++ (compiled to WebAssembly with emscripten, bound with embind): the
// protocol codec, the client core (the lighting state the server's messages build, the map-set
// assembly: client/net), the placement and shadow budget (client/app) and the renderer are the
// project's own, the native client's; this file is the page's API over them (embind glue). JavaScript owns what only a browser has (camera, sensors,
// the WebSocket) and moves bytes: messages to send come out of here encoded, messages received
// go in here to be decoded and turned into lighting, and the camera frame is composited with the
// object into the page's canvas by the same renderer and shaders as the native client.
// Tracking: the page's worker finds the marker with opencv.js (marker_worker.js) and hands its
// solvePnP result here, where the native client's pose filter and WorldFromMarker
// (arlight_track_core) turn it into the object's place.
#include <GLES3/gl3.h>
#include <emscripten/bind.h>
#include <emscripten/val.h>

#include <chrono>
#include <cmath>
#include <glm/gtc/quaternion.hpp>
#include <optional>
#include <string>
#include <vector>

#include "arlight/error.hpp"
#include "arlight/lighting_state.hpp"
#include "arlight/placement.hpp"
#include "arlight/pose.hpp"
#include "arlight/render.hpp"
#include "arlight/track/pose_filter.hpp"
#include "arlight/track/pose_math.hpp"
#include "arlight/track/world_from_marker.hpp"
#include "arlight/wire.hpp"
#include "yuv_frame.hpp"

namespace arlight::web {

using emscripten::val;

namespace {

// The maps the page asks for: the irradiance map and reflection maps for the materials it
// offers, small enough for a phone (lat-long 2N x N).
const std::vector<float> kShininess = {1, 10, 40, 160, 640};
constexpr int kMapSize = 128;
// The object stands this many marker sides tall, as in the native client (client_app.hpp).
constexpr double kObjectHeightPerMarker = 1.5;
constexpr double kDefaultMarkerSize = 0.2;  // metres: the native client's default marker
// How far ahead of the newest tracked frame the camera's position is extrapolated (the pose
// filter's reset time: beyond it the marker counts as lost).
constexpr double kExtrapolateSeconds = 0.5;
// Soft shadows (tutorial §6.4): at most this many hard shadows, as many as hold the target frame
// rate (the native client's --shadow-lights and --target-fps defaults).
constexpr int kDefaultShadowLights = 16;
constexpr double kDefaultTargetFps = 30.0;

val bytes_to_js(const std::vector<std::uint8_t>& bytes) {
  // A copy: the view into the module's memory would change under the next call.
  return val::global("Uint8Array").new_(emscripten::typed_memory_view(bytes.size(), bytes.data()));
}

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

render::Material material_named(const std::string& name) {
  return render::preset_material(name, kShininess.back());  // as sharp as the sharpest map
}

}  // namespace

class WebClient {
 public:
  WebClient(const std::string& canvas, int width, int height)
      : WebClient(canvas, width, height, render::make_sphere(0.5f, 48, 96)) {}

  // ---- messages to send ----
  val hello(const std::string& device, const std::string& token, const std::string& resume) {
    return bytes_to_js(wire::encode(
        wire::Hello{wire::kProtocolVersion,
                    "arlight-web 0.1",
                    device,
                    token,
                    {"maps", "jpeg", wire::kCapabilityTilesHalf, wire::kCapabilityExposureUnknown},
                    resume}));
  }
  // Browsers do not report intrinsics: a pinhole of the given vertical field of view (degrees).
  void set_fov(double fov_y_deg) {
    if (!(fov_y_deg > 10.0 && fov_y_deg < 150.0))
      throw std::invalid_argument("field of view " + std::to_string(fov_y_deg) +
                                  " is not in (10, 150) degrees");
    set_focal(0.5 * height_ / std::tan(0.5 * fov_y_deg * M_PI / 180.0));
  }
  // A focal length in pixels (square pixels, principal point at the centre): the page's
  // refinement from the marker's views (intrinsics.js). The page then sends intrinsics() again.
  void set_focal(double f) {
    if (!(f > 0.05 * height_ && f < 20.0 * height_))
      throw std::invalid_argument("focal length " + std::to_string(f) + " px is out of range");
    camera_.fx = camera_.fy = f;
    camera_.cx = 0.5 * width_ - 0.5, camera_.cy = 0.5 * height_ - 0.5;
  }
  val camera() const {
    val k = val::object();
    k.set("fx", camera_.fx), k.set("fy", camera_.fy), k.set("cx", camera_.cx);
    k.set("cy", camera_.cy), k.set("width", width_), k.set("height", height_);
    return k;
  }
  // The marker's side (metres): the object stands 1.5 of them tall on it.
  void set_marker_size(double size_m) {
    if (!(size_m > 0.005 && size_m < 10.0))
      throw std::invalid_argument("marker size " + std::to_string(size_m) + " m is out of range");
    object_height_ = kObjectHeightPerMarker * size_m;
    model_ = render::standing_on_marker(mesh_bounds_, float(object_height_));
  }
  val intrinsics() { return bytes_to_js(wire::encode(wire::CameraIntrinsicsMessage{camera_})); }
  val frame(double sequence, double timestamp, double qw, double qx, double qy, double qz,
            const val& jpeg) {
    wire::CameraFrame f;
    f.sequence = std::uint64_t(sequence);
    f.info.timestamp = timestamp;
    f.info.exposure = wire::kLockedExposureSeconds;  // exposure:unknown: the daemon locks it
    f.info.gain = 1.0;
    f.info.orientation = glm::normalize(glm::dquat(qw, qx, qy, qz));
    f.format = wire::PixelFormat::Jpeg;
    f.width = std::uint32_t(width_), f.height = std::uint32_t(height_);
    f.data = emscripten::convertJSArrayToNumberVector<std::uint8_t>(jpeg);
    ++frames_sent_;
    return bytes_to_js(wire::encode(f));
  }
  val request_maps() {
    state_.expect_maps(std::vector<double>(kShininess.begin(), kShininess.end()));
    return bytes_to_js(
        wire::encode(wire::RequestMaps{kShininess, kMapSize, Projection::LatLong, "auto"}));
  }

  // Where and when the phone is (the browser's geolocation, with its user's consent: the sun),
  // as a Location message to send, or null when the server does not take one. The orientation
  // is north-referenced when it comes from the absolute orientation sensor (a compass).
  val location(double latitude, double longitude, double altitude, double utc_seconds,
               bool north_referenced) {
    const auto& welcome = state_.welcome();
    if (!welcome || !wire::has_capability(welcome->capabilities, wire::kServerCapabilityLocation))
      return val::null();
    wire::Location l;
    l.where = {latitude, longitude, std::isfinite(altitude) ? altitude : 0.0};
    if (const std::string e = geo_location_error(l.where); !e.empty())
      throw std::invalid_argument("location: " + e);
    l.utc_seconds = utc_seconds;
    l.north_referenced = north_referenced;
    return bytes_to_js(wire::encode(l));
  }

  // ---- messages received: the message's name, or "refused: why" (the page then closes) ----
  std::string receive(const val& bytes) {
    const std::vector<std::uint8_t> envelope =
        emscripten::convertJSArrayToNumberVector<std::uint8_t>(bytes);
    wire::Message m;
    try {
      m = wire::decode(envelope);
    } catch (const wire::DecodeError& e) {
      last_error_ = std::string("bad message from the server: ") + e.what();
      return "refused: " + last_error_;
    }
    const std::string name = wire::message_name(m);
    switch (state_.receive(std::move(m))) {
      case client::LightingState::Change::Error:
        last_error_ = state_.error()->first + ": " + state_.error()->second;
        break;
      case client::LightingState::Change::Update:
        if (!state_.lighting().maps) renderer_.set_sh(*state_.lighting().sh);
        break;
      case client::LightingState::Change::MapSet:
        renderer_.set_maps(state_.lighting().maps->shininess, state_.lighting().maps->maps);
        break;
      default:
        break;
    }
    return name;
  }

  // ---- tracking ----
  // The marker seen in the frame taken at `timestamp` (seconds, the page's clock): solvePnP's
  // rvec/tvec (marker -> OpenCV camera) and the camera's orientation (camera -> world) when the
  // frame was taken. Returns the camera's pose in the marker frame as measured and as smoothed:
  // {raw: {position, orientation}, smoothed: {...}} (orientation [w, x, y, z]).
  val marker_seen(double timestamp, double rx, double ry, double rz, double tx, double ty,
                  double tz, double qw, double qx, double qy, double qz) {
    const glm::dvec3 rvec(rx, ry, rz), tvec(tx, ty, tz);
    if (!std::isfinite(timestamp) || !std::isfinite(glm::length(rvec)) ||
        !std::isfinite(glm::length(tvec)) || !(tz > 0))
      throw std::invalid_argument("marker pose: not finite, or the marker behind the camera");
    const Pose raw = track::pose_from_opencv(rvec, tvec);
    const glm::dquat world_from_camera = glm::normalize(glm::dquat(qw, qx, qy, qz));
    const Pose smoothed = filter_.update(raw, timestamp);
    world_from_marker_.add(timestamp, world_from_camera, raw.orientation);
    placement_.tracked(timestamp, smoothed, filter_.velocity(), world_from_camera);
    ++tracked_frames_;
    val out = val::object();
    out.set("raw", pose_to_js(raw));
    out.set("smoothed", pose_to_js(smoothed));
    val velocity = val::array();
    for (int i = 0; i < 3; ++i) velocity.call<void>("push", filter_.velocity()[i]);
    out.set("velocity", velocity);
    return out;
  }

  // ---- the camera frame and the composite ----
  // The GL texture the page uploads its video frame into (texSubImage2D from the <video>: no
  // copy through JavaScript), R, G, B, the renderer's size, top row first.
  unsigned camera_texture() const { return renderer_.camera_texture(); }

  // Or the frame's planes (WebCodecs VideoFrame.copyTo, layout "NV12" or "I420"): the page
  // uploads them into these textures, then convert_yuv() fills camera_texture() from them.
  unsigned yuv_plane_texture(const std::string& layout, int plane) {
    return yuv().plane_texture(yuv_layout(layout), plane);
  }
  void convert_yuv(const std::string& layout, const std::string& matrix, bool full_range) {
    yuv().convert(yuv_layout(layout), matrix, full_range, renderer_.camera_texture());
  }

  // Composites the object, lit by the newest lighting, over the frame in camera_texture() and
  // shows it in the canvas; the frame's time (seconds, the clock markerSeen's timestamps use) and
  // the camera's orientation then (camera -> world, as sent) place it. Milliseconds of this call.
  double render(double timestamp, double qw, double qx, double qy, double qz) {
    const auto t0 = std::chrono::steady_clock::now();
    const glm::dquat world_from_camera = glm::normalize(glm::dquat(qw, qx, qy, qz));
    // On the marker: the newest tracked pose (the worker's result trails the shown frame),
    // turned by the rotation the orientation sensor measured since its frame and moved on by
    // the pose filter's velocity. After the marker is lost the object stays there, turned by
    // the sensor alone, until it is seen again. Before any marker: the preview.
    const auto on_marker = placement_.camera_in_marker(timestamp, world_from_camera);
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
      // On the real floor: only where a marker says it is.
      shadow_drawn_ = placement_.has_track();
      renderer_.set_shadow(shadow_.settings(shadow_drawn_, state_.lighting()));
      renderer_.draw(mesh_, material_, model_);
    }
    // The camera's exposure as arlightd estimated it for the newest frame it processed (the
    // browser cannot say; its auto-exposure moves as the phone turns), in the map's units.
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

  // Soft shadows (tutorial §6, §6.4; arlight-client's --shadow-lights and --target-fps): at most
  // max_lights hard shadows blended, as many as hold the page at target_fps (0: always
  // max_lights). Throws for max_lights outside [1, 32] or a negative or non-finite target.
  void set_shadow_lights(int max_lights, double target_fps) {
    if (max_lights < 1 || max_lights > render::kMaxShadowLights)
      throw std::invalid_argument("shadow lights " + std::to_string(max_lights) + ": 1 to " +
                                  std::to_string(render::kMaxShadowLights));
    if (!(target_fps >= 0) || !std::isfinite(target_fps))
      throw std::invalid_argument("target frame rate: a number of frames a second, 0 for none");
    shadow_ = client_app::ShadowBudget(max_lights, target_fps);
  }

  // The page's whole frame (the camera frame's upload and render()) took `ms`: the frame-rate
  // control's measure, counted for the frames that drew a shadow (with however many hard
  // shadows the room's clusters gave: a budget too small for a compact cluster draws none).
  void frame_took(double ms) {
    shadow_.frame_took(ms, shadow_drawn_);
  }

  void set_material(const std::string& name) {
    material_ = material_named(name);
    material_name_ = name;
  }

  // What glass shows through it: "live" (the camera frame behind it) or "maps" (the room as
  // captured); render::Refraction, arlight-client --glass.
  void set_refraction(const std::string& name) {
    const auto refraction = render::refraction_named(name);
    if (!refraction) throw std::invalid_argument("refraction '" + name + "': live or maps");
    renderer_.set_refraction(*refraction);
  }

  // "maps", "hemisphere" or "hemisphere-occlusion" (render::Shading, arlight-client --shading).
  void set_shading(const std::string& name) {
    const auto shading = render::shading_named(name);
    if (!shading)
      throw std::invalid_argument("shading '" + name +
                                  "': maps, hemisphere or hemisphere-occlusion");
    renderer_.set_shading(*shading);
  }

  // The dissertation's colour correction (render::ColourCorrection, arlight-client's --tone
  // camera,CORRECTION): "none", "brightness", "contrast" or "match".
  void set_colour(const std::string& name) {
    const auto colour = render::colour_correction_named(name);
    if (!colour)
      throw std::invalid_argument("colour '" + name + "': none, brightness, contrast or match");
    colour_ = *colour;
  }

  // The object: "sphere", or a model's .glb bytes (the page fetches models/NAME.glb; no Draco in
  // this build). Returns why a file is unusable (naming it; the object stays what it was), or "".
  std::string set_model(const std::string& name, const val& glb) {
    render::Mesh mesh;
    try {
      mesh = name == "sphere"
                 ? render::make_sphere(0.5f, 48, 96)
                 : render::load_gltf(emscripten::convertJSArrayToNumberVector<std::uint8_t>(glb),
                                     name + ".glb");
    } catch (const InputError& e) {
      return e.what();
    }
    mesh_ = render::GpuMesh(mesh);
    mesh_bounds_ = mesh.bounds;
    model_name_ = name;
    model_vertices_ = mesh.vertex_count();
    model_ = render::standing_on_marker(mesh_bounds_, float(object_height_));
    return {};
  }

  // Where the object's centre is in the last composite (pixels, row 0 at the top), or null when
  // it is behind the camera or nothing was drawn yet.
  val object_pixel() const { return pixel_of({0.0, 0.0, 0.5 * object_height_}); }

  // Where the floor just in front of the object is in the last composite (pixels, row 0 at the
  // top): the point of the marker plane 1.15 footprint half-widths from the object's centre
  // towards the camera, inside its contact shadow and never behind the object; null as
  // object_pixel().
  val floor_pixel() const {
    if (!last_camera_from_scene_) return val::null();
    glm::dvec3 lo(1e30), hi(-1e30);
    for (int i = 0; i < 8; ++i) {
      const glm::dvec3 corner(i & 1 ? mesh_bounds_.max.x : mesh_bounds_.min.x,
                              i & 2 ? mesh_bounds_.max.y : mesh_bounds_.min.y,
                              i & 4 ? mesh_bounds_.max.z : mesh_bounds_.min.z);
      const glm::dvec3 q = glm::dvec3(model_ * glm::vec4(glm::vec3(corner), 1.0f));
      lo = glm::min(lo, q), hi = glm::max(hi, q);
    }
    const glm::dvec2 centre = 0.5 * glm::dvec2(lo + hi);
    const double half = 0.5 * std::max(hi.x - lo.x, hi.y - lo.y);
    const glm::dvec3 eye = glm::dvec3(glm::inverse(*last_camera_from_scene_)[3]);
    const glm::dvec2 towards = glm::dvec2(eye) - centre;
    if (glm::length(towards) < 1e-9) return val::null();  // looking straight down at it
    return pixel_of(glm::dvec3(centre + 1.15 * half * glm::normalize(towards), 0.0));
  }

  // What the last render() drew with, for a renderer elsewhere to draw the same (tests, tools):
  // {camera_from_scene, model: 16 numbers each, column-major; world_from_scene: [w, x, y, z];
  // exposure; material, shading, refraction, colour}, or null before anything was drawn.
  val view() const {
    if (!last_camera_from_scene_) return val::null();
    const auto matrix = [](const auto& m) {
      val a = val::array();
      for (int c = 0; c < 4; ++c)
        for (int r = 0; r < 4; ++r) a.call<void>("push", double(m[c][r]));
      return a;
    };
    val q = val::array();
    for (const double v : {last_world_from_scene_.w, last_world_from_scene_.x,
                           last_world_from_scene_.y, last_world_from_scene_.z})
      q.call<void>("push", v);
    val out = val::object();
    out.set("camera_from_scene", matrix(*last_camera_from_scene_));
    out.set("model", matrix(model_));
    out.set("world_from_scene", q);
    out.set("exposure", frame_exposure());
    out.set("material", material_name_);
    out.set("shading", std::string(render::shading_name(renderer_.shading())));
    out.set("refraction", std::string(render::refraction_name(renderer_.refraction())));
    out.set("colour", std::string(render::colour_correction_name(colour_)));
    return out;
  }

  val status() const {
    const client::Lighting& l = state_.lighting();
    const auto& welcome = state_.welcome();
    val s = val::object();
    s.set("connected", welcome.has_value());
    s.set("session_id", welcome ? welcome->session_id : std::string());
    s.set("server_version", welcome ? welcome->server_version : std::string());
    s.set("updates", double(state_.updates()));
    s.set("last_sequence", double(l.frame_sequence));
    s.set("frames_processed", double(l.frames_processed));
    s.set("map_sets", double(state_.map_sets()));
    s.set("coverage", l.coverage);
    s.set("estimated", l.estimated);
    s.set("frame_exposure", frame_exposure());
    s.set("frames_encoded", double(frames_sent_));
    s.set("frames_rendered", double(frames_rendered_));
    const auto source = renderer_.lighting_source();
    s.set("lighting", std::string(source == render::LightingSource::Maps ? "maps"
                                  : source == render::LightingSource::Sh ? "sh"
                                                                         : "none"));
    s.set("shading", std::string(render::shading_name(renderer_.shading())));
    s.set("material", material_name_);
    s.set("refraction", std::string(render::refraction_name(renderer_.refraction())));
    s.set("colour", std::string(render::colour_correction_name(colour_)));
    s.set("sun", std::string(sun_state_name(l.sun_state)));
    s.set("sun_direction", vector_to_js(l.sun_direction));
    s.set("last_error", last_error_);
    // Bands 0-2 of the live SH (RGB triples, index l(l+1)+m): the room's irradiance.
    val sh = val::array();
    for (int k = 0; k < 9 && l.sh && k < int(l.sh->c.size()); ++k)
      for (int ch = 0; ch < 3; ++ch) sh.call<void>("push", l.sh->c[std::size_t(k)][ch]);
    s.set("sh", sh);
    s.set("light_direction", vector_to_js(l.dominant_direction));
    s.set("tracked_frames", double(tracked_frames_));
    s.set("tracking", std::string(placement_.has_track() ? "marker" : "preview"));
    s.set("focal_px", camera_.fx);
    s.set("model", model_name_);
    s.set("model_vertices", double(model_vertices_));
    // The last composite's soft shadow: hard shadows blended (0: none drawn), and the time to
    // issue it; the count the frame-rate control holds, its limit and its target.
    s.set("shadow_lights", renderer_.timings().shadow_lights);
    s.set("shadow_ms", renderer_.timings().shadow_ms);
    s.set("shadow_light_budget", shadow_.lights());
    s.set("max_shadow_lights", shadow_.max_lights());
    s.set("target_fps", shadow_.target_fps());
    return s;
  }

 private:
  // The marker's rotation into the world: the estimate over its sightings, or the newest one's.
  glm::dquat world_from_marker() const {
    if (const auto w = world_from_marker_.world_from_marker()) return *w;
    return placement_.world_from_marker_of_track().value_or(glm::dquat(1.0, 0.0, 0.0, 0.0));
  }

  // The exposure arlightd took the newest frame at (the browser cannot say; its auto-exposure
  // moves as the phone turns), in the map's units; the locked one until an update says.
  double frame_exposure() const {
    const double e = state_.lighting().frame_exposure;
    return e > 0 ? e : wire::kLockedExposureSeconds;
  }

  // A scene point's pixel in the last composite, or null when it is behind the camera or
  // nothing was drawn yet.
  val pixel_of(const glm::dvec3& scene_point) const {
    if (!last_camera_from_scene_) return val::null();
    const glm::dvec3 c = *last_camera_from_scene_ * glm::dvec4(scene_point, 1.0);
    if (c.z >= -1e-3) return val::null();  // looking down -z
    val p = val::array();
    p.call<void>("push", camera_.cx + camera_.fx * (c.x / -c.z));
    p.call<void>("push", camera_.cy - camera_.fy * (c.y / -c.z));
    return p;
  }

  static YuvLayout yuv_layout(const std::string& name) {
    if (name == "NV12") return YuvLayout::Nv12;
    if (name == "I420") return YuvLayout::I420;
    throw std::invalid_argument("frame layout '" + name + "': NV12 or I420");
  }
  YuvFrame& yuv() {
    if (!yuv_) yuv_.emplace(width_, height_, "/shaders");
    return *yuv_;
  }

  WebClient(const std::string& canvas, int width, int height, const render::Mesh& sphere)
      : context_(render::GlContext::canvas(canvas)),
        renderer_(width, height, "/shaders"),
        mesh_bounds_(sphere.bounds),
        mesh_(sphere),
        model_vertices_(sphere.vertex_count()),
        material_(material_named("plastic")),
        width_(width),
        height_(height) {
    camera_.width = width, camera_.height = height;
    set_fov(63.0);
    set_marker_size(kDefaultMarkerSize);
    set_shadow_lights(kDefaultShadowLights, kDefaultTargetFps);
  }

  render::GlContext context_;
  render::Renderer renderer_;
  render::Bounds mesh_bounds_;
  render::GpuMesh mesh_;
  std::string model_name_ = "sphere";
  std::size_t model_vertices_ = 0;
  render::Material material_;
  std::string material_name_ = "plastic";
  render::ColourCorrection colour_ = render::ColourCorrection::None;
  glm::mat4 model_{1.0f};
  double object_height_ = 0;
  int width_, height_;
  CameraIntrinsics camera_;
  // The newest tracked pose (smoothed, camera -> marker), carried on to the frame shown.
  client_app::MarkerPlacement placement_{{.hold_s = std::numeric_limits<double>::infinity(),
                                          .extrapolate_s = kExtrapolateSeconds}};
  track::PoseFilter filter_;
  // One sample is enough to light the object; the window then averages the tracker's noise.
  track::WorldFromMarker world_from_marker_{track::WorldFromMarkerOptions{.min_samples = 1}};
  std::uint64_t tracked_frames_ = 0;
  std::optional<glm::dmat4> last_camera_from_scene_;
  glm::dquat last_world_from_scene_{1.0, 0.0, 0.0, 0.0};
  std::optional<YuvFrame> yuv_;
  client::LightingState state_;  // what arlightd's messages built
  std::string last_error_;
  std::uint64_t frames_sent_ = 0, frames_rendered_ = 0;
  client_app::ShadowBudget shadow_{kDefaultShadowLights, kDefaultTargetFps};
  bool shadow_drawn_ = false;  // the last render() drew the shadow catcher
};

EMSCRIPTEN_BINDINGS(arlight_web) {
  emscripten::class_<WebClient>("WebClient")
      .constructor<std::string, int, int>()
      .function("hello", &WebClient::hello)
      .function("setFov", &WebClient::set_fov)
      .function("setFocal", &WebClient::set_focal)
      .function("camera", &WebClient::camera)
      .function("setMarkerSize", &WebClient::set_marker_size)
      .function("markerSeen", &WebClient::marker_seen)
      .function("intrinsics", &WebClient::intrinsics)
      .function("frame", &WebClient::frame)
      .function("requestMaps", &WebClient::request_maps)
      .function("receive", &WebClient::receive)
      .function("cameraTexture", &WebClient::camera_texture)
      .function("yuvPlaneTexture", &WebClient::yuv_plane_texture)
      .function("convertYuv", &WebClient::convert_yuv)
      .function("render", &WebClient::render)
      .function("setShadowLights", &WebClient::set_shadow_lights)
      .function("frameTook", &WebClient::frame_took)
      .function("setMaterial", &WebClient::set_material)
      .function("setShading", &WebClient::set_shading)
      .function("setRefraction", &WebClient::set_refraction)
      .function("setColour", &WebClient::set_colour)
      .function("location", &WebClient::location)
      .function("setModel", &WebClient::set_model)
      .function("status", &WebClient::status)
      .function("objectPixel", &WebClient::object_pixel)
      .function("floorPixel", &WebClient::floor_pixel)
      .function("view", &WebClient::view);
}

}  // namespace arlight::web
