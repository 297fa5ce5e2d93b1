// The browser client's C++ (compiled to WebAssembly with emscripten, bound with embind in
// web_bindings.cpp): the page's API over the project's own code, the native client's — the
// protocol codec and the client core (the lighting state the server's messages build, the
// map-set assembly, the messages a client sends: client/net), the placement and the shadow
// budget (client/app), the tracking core and the renderer. JavaScript owns what only a browser
// has (camera, sensors, the WebSocket) and moves bytes: messages to send come out of here
// encoded, messages received go in here, and the camera frame is composited with the object
// into the page's canvas by the same renderer and shaders as the native client. Tracking: the
// page's worker finds the marker with opencv.js (marker_worker.js) and hands its solvePnP result
// here, where the native client's pose filter and WorldFromMarker place the object.
//   web_client.cpp   messages, lighting, tracking and the composite
//   web_scene.cpp    the camera's focal length, the object, its material and the modes
//   web_status.cpp   what the page and its tests read back: status(), view(), pixels
#pragma once

#include <emscripten/val.h>

#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "arlight/app/placement.hpp"
#include "arlight/net/frame_pacer.hpp"
#include "arlight/net/lighting_state.hpp"
#include "arlight/net/unsaved_frames.hpp"
#include "arlight/render/render.hpp"
#include "arlight/track/pose_filter.hpp"
#include "arlight/track/world_from_marker.hpp"
#include "yuv_frame.hpp"

namespace arlight::web {

using emscripten::val;

// The maps the page asks for: the irradiance map and reflection maps for the materials it
// offers, small enough for a phone (lat-long 2N x N).
inline const std::vector<double> kShininess = {1, 10, 40, 160, 640};
inline constexpr int kMapSize = 128;
// ... or, for a metallic-roughness material, the room's GGX chain from this face (128 -> 16).
inline constexpr int kGgxFace = 128;

// JavaScript values of the page's API.
val vector_to_js(const glm::vec3& v);                     // [x, y, z]
val pose_to_js(const Pose& p);  // {position: [x, y, z], orientation: [w, x, y, z]}

class WebClient {
 public:
  WebClient(const std::string& canvas, int width, int height);

  // ---- messages to send (encoded) ----
  // `join`: a session id to capture into as a contributor (issue 49 §1, the page's #join=ID:
  // its token is a join token or the session's), else empty; `resume` is then ignored.
  val hello(const std::string& device, const std::string& token, const std::string& resume,
            const std::string& join);
  // The session's own page: a RequestJoinToken for its "capture with another phone" link, or
  // null (a contributor's page, or a server whose Welcome does not name "join").
  val request_join_token() const;
  val intrinsics();
  // A camera frame, its JPEG `reduction` times smaller each side than the camera (1: its size)
  // and encoded at `quality` (1-100): what frame_due() said.
  val frame(double sequence, double timestamp, double qw, double qx, double qy, double qz,
            const val& jpeg, int reduction, int quality);
  // Whether a frame due at `timestamp` (seconds, the clock frame() is given) should go, how
  // reduced and at which JPEG quality: {send, reduction, quality}, as the daemon's frame advice
  // says (client::FramePacer).
  val frame_due(double timestamp);
  // No frame lost in a fail-over (issue 36 §5, PROTOCOL.md): the frames sent that no checkpoint
  // holds yet are kept (up to kUnsavedBytes); after a Welcome whose session lacks some of them,
  // the next one to send again, encoded, when fewer than the in-flight limit are unanswered
  // (timestamp as frame_due's), else null. While any waits, the page sends no newer frame
  // (the session would take the older ones as duplicates).
  val resend_frame(double timestamp);
  bool frames_waiting() const { return unsaved_.waiting(); }
  // The maps the material needs: the Phong set, or the GGX chain for a metallic-roughness one.
  val request_maps();
  // The same when the material now needs the other kind than was last asked for, else null.
  val request_maps_if_changed();
  // Where and when the phone is (the browser's geolocation, with its user's consent: the sun),
  // as a Location message to send, or null when the server does not take one. The orientation
  // is north-referenced when it comes from the absolute orientation sensor (a compass).
  val location(double latitude, double longitude, double altitude, double utc_seconds,
               bool north_referenced);

  // ---- messages received: the message's name, or "refused: why" (the page then closes) ----
  std::string receive(const val& bytes);
  // The newest LightingUpdate's frame sequence (what status() says, without the rest of it).
  double last_sequence() const { return double(state_.lighting().frame_sequence); }

  // ---- tracking ----
  // The marker seen in the frame taken at `timestamp` (seconds, the page's clock): solvePnP's
  // rvec/tvec (marker -> OpenCV camera) and the camera's orientation (camera -> world) when the
  // frame was taken. Returns the camera's pose in the marker frame as measured and as smoothed,
  // and its velocity: {raw: {position, orientation}, smoothed: {...}, velocity: [x, y, z]}.
  val marker_seen(double timestamp, double rx, double ry, double rz, double tx, double ty,
                  double tz, double qw, double qx, double qy, double qz);

  // ---- the camera frame and the composite ----
  // The GL texture the page uploads its video frame into (texSubImage2D from the <video>: no
  // copy through JavaScript), R, G, B, the renderer's size, top row first.
  unsigned camera_texture() const { return renderer_.camera_texture(); }
  // Or the frame's planes (WebCodecs VideoFrame.copyTo, layout "NV12" or "I420"): the page
  // uploads them into these textures, then convert_yuv() fills camera_texture() from them.
  unsigned yuv_plane_texture(const std::string& layout, int plane);
  void convert_yuv(const std::string& layout, const std::string& matrix, bool full_range);
  // Composites the object, lit by the newest lighting, over the frame in camera_texture() and
  // shows it in the canvas; the frame's time (seconds, the clock markerSeen's timestamps use)
  // and the camera's orientation then (camera -> world, as sent) place it. Milliseconds taken.
  double render(double timestamp, double qw, double qx, double qy, double qz);
  // The page's whole frame (the camera frame's upload and render()) took `ms`: the frame-rate
  // control's measure, counted for the frames that drew a shadow.
  void frame_took(double ms) { shadow_.frame_took(ms, shadow_drawn_); }

  // ---- the camera, the object and the modes (web_scene.cpp) ----
  // Browsers do not report intrinsics: a pinhole of the given vertical field of view (degrees).
  void set_fov(double fov_y_deg);
  // A focal length in pixels (square pixels, principal point at the centre): the page's
  // refinement from the marker's views (intrinsics.js). The page then sends intrinsics() again.
  void set_focal(double f);
  val camera() const;
  // The marker's side (metres): the object stands 1.5 of them tall on it.
  void set_marker_size(double size_m);
  // Soft shadows (tutorial §6, §6.4; arlight-client's --shadow-lights and --target-fps): at most
  // max_lights hard shadows blended, as many as hold the page at target_fps (0: always
  // max_lights). Throws for max_lights outside [1, 32] or a negative or non-finite target.
  void set_shadow_lights(int max_lights, double target_fps);
  // A preset (render::preset_material: plastic, matte, metal, glass, gold, porcelain) or "model":
  // the model's own glTF materials (the Phong default on parts without one).
  void set_material(const std::string& name);
  // "live" (the camera frame behind the glass) or "maps" (render::Refraction, --glass).
  void set_refraction(const std::string& name);
  // "maps", "hemisphere" or "hemisphere-occlusion" (render::Shading, --shading).
  void set_shading(const std::string& name);
  // The dissertation's colour correction (render::ColourCorrection, --tone camera,CORRECTION):
  // "none", "brightness", "contrast" or "match".
  void set_colour(const std::string& name);
  // The object: "sphere", or a model's .glb bytes (the page fetches models/NAME.glb; no Draco in
  // this build) with its materials and textures. Returns why a file is unusable (naming it, and
  // the material and field where one is at fault; the object stays what it was), or "".
  std::string set_model(const std::string& name, const val& glb);

  // ---- what the page and its tests read back (web_status.cpp) ----
  val status() const;
  // Where the object's centre is in the last composite (pixels, row 0 at the top), or null when
  // it is behind the camera or nothing was drawn yet.
  val object_pixel() const;
  // Whether the last render() placed the object by the marker's pose (not the preview).
  bool placed_on_marker() const { return placed_on_marker_; }
  // Where the floor just in front of the object is in the last composite: the point of the
  // marker plane 1.15 footprint half-widths from the object's centre towards the camera, inside
  // its contact shadow and never behind the object; null as object_pixel().
  val floor_pixel() const;
  // What the last render() drew with, for a renderer elsewhere to draw the same (tests, tools):
  // {camera_from_scene, model: 16 numbers each, column-major; world_from_scene: [w, x, y, z];
  // exposure; material, shading, refraction, colour}, or null before anything was drawn.
  val view() const;

 private:
  WebClient(const std::string& canvas, int width, int height, const render::Mesh& sphere);
  glm::dquat world_from_marker() const;
  // The materials draw() gives the mesh's parts: the model's with material "model", else none
  // (material_ everywhere).
  std::span<const render::Material> draw_materials() const;
  double frame_exposure() const;
  val pixel_of(const glm::dvec3& scene_point) const;
  YuvFrame& yuv();

  render::GlContext context_;
  render::Renderer renderer_;
  // The object: its mesh and bounds, its model matrix (standing on the marker), its material.
  render::Bounds mesh_bounds_;
  render::GpuMesh mesh_;
  std::string model_name_ = "sphere";
  std::size_t model_vertices_ = 0;
  render::Material material_;
  std::string material_name_ = "plastic";
  // The model's own materials (a glTF's), drawn with material "model", and what its reader
  // warned of (status's model_warnings).
  std::vector<render::Material> model_materials_;
  std::vector<std::string> model_warnings_;
  bool requested_ggx_ = false;  // the last RequestMaps asked for the GGX chain
  std::string join_;            // the session this page contributes to (hello's join)
  render::ColourCorrection colour_ = render::ColourCorrection::None;
  glm::mat4 model_{1.0f};
  double object_height_ = 0;
  int width_, height_;
  CameraIntrinsics camera_;
  // Tracking: the pose filter, the marker's rotation into the world over its sightings (one is
  // enough to light the object; the window then averages the tracker's noise), and the newest
  // tracked pose carried on to the frame shown (0.5 s at most: the filter's reset time).
  track::PoseFilter filter_;
  track::WorldFromMarker world_from_marker_{track::WorldFromMarkerOptions{.min_samples = 1}};
  client_app::MarkerPlacement placement_{
      {.hold_s = std::numeric_limits<double>::infinity(), .extrapolate_s = 0.5}};
  std::uint64_t tracked_frames_ = 0;
  std::optional<glm::dmat4> last_camera_from_scene_;
  glm::dquat last_world_from_scene_{1.0, 0.0, 0.0, 0.0};
  std::optional<YuvFrame> yuv_;
  client::LightingState state_;  // what arlightd's messages built
  std::string last_error_;
  std::uint64_t frames_sent_ = 0, frames_rendered_ = 0;
  // The daemon's frame advice, and at most kMaxInFlight frames unanswered by a LightingUpdate
  // (issue 36 §1: the page's frames used to queue for seconds behind each other).
  static constexpr int kMaxInFlight = 2;
  client::FramePacer pacer_;
  static constexpr std::size_t kUnsavedBytes = std::size_t(8) << 20;  // a phone's: ~4 s of frames
  client::UnsavedFrames unsaved_{kUnsavedBytes};
  // Soft shadows: the native client's --shadow-lights and --target-fps defaults.
  client_app::ShadowBudget shadow_{16, 30.0};
  bool shadow_drawn_ = false;  // the last render() drew the shadow catcher
  bool placed_on_marker_ = false;
};

}  // namespace arlight::web
