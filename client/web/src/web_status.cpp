// The page's API (web_client.hpp): what the page and its tests read back — the status panel's
// figures, the last composite's view and where the object and its floor landed in it.
#include "web_client.hpp"

namespace arlight::web {

val WebClient::status() const {
  const client::Lighting& l = state_.lighting();
  const auto& welcome = state_.welcome();
  val s = val::object();
  s.set("connected", welcome.has_value());
  s.set("session_id", welcome ? welcome->session_id : std::string());
  s.set("server_version", welcome ? welcome->server_version : std::string());
  // The newest frame the (resumed) session holds: the page numbers its frames after it.
  s.set("session_last_sequence", welcome ? double(welcome->last_sequence) : 0.0);
  s.set("session_resumed", welcome ? welcome->resumed : false);
  // Every frame up to this one is in the session's newest checkpoint (0: none yet).
  const auto& update = state_.last_update();
  s.set("saved_sequence", update ? double(update->saved_sequence) : 0.0);
  s.set("updates", double(state_.updates()));
  s.set("last_sequence", double(l.frame_sequence));
  s.set("frames_processed", double(l.frames_processed));
  s.set("map_sets", double(state_.map_sets()));
  // The room's GGX chain (a metallic-roughness material asks for it): its level 0's face, 0: none.
  s.set("ggx_face", l.ggx ? l.ggx->maps.front().layout.face_size() : 0);
  s.set("maps_requested", std::string(requested_ggx_ ? "ggx" : "phong"));
  s.set("coverage", l.coverage);
  s.set("estimated", l.estimated);
  // How far arlightd says the light may be off (0: not stated, 10: nothing seen yet), its map
  // in percent (light_error_zones x 2 light_error_zones equal-area cells, PROTOCOL.md), and the
  // view it asks for (world frame; null: none).
  s.set("light_error", l.light_error);
  s.set("light_error_zones", l.light_error_zones);
  val error_map = val::array();
  for (const std::uint8_t e : l.light_error_map) error_map.call<void>("push", int(e));
  s.set("light_error_map", error_map);
  s.set("next_view", l.next_view ? vector_to_js(*l.next_view) : val::null());
  s.set("next_view_gain", l.next_view_gain);
  s.set("frame_exposure", frame_exposure());
  s.set("frames_encoded", double(frames_sent_));
  // Fail-over (issue 36 §5): frames sent again after a resume, and those kept for it now.
  s.set("frames_resent", double(unsaved_.resent()));
  s.set("frames_kept", double(unsaved_.size()));
  // The daemon's frame advice (issue 37 §1) and the frames it held back.
  s.set("frames_held_back", double(pacer_.held_back()));
  s.set("frames_held_in_flight", double(pacer_.held_in_flight()));
  s.set("advised_width", pacer_.advised_width());
  s.set("advised_height", pacer_.advised_height());
  s.set("advised_fps", pacer_.advised_fps());
  s.set("advised_frame_bytes", double(pacer_.advised_frame_bytes()));
  s.set("jpeg_quality", pacer_.quality());
  s.set("frames_rendered", double(frames_rendered_));
  const auto source = renderer_.lighting_source();
  s.set("lighting", std::string(source == render::LightingSource::Maps ? "maps"
                                : source == render::LightingSource::Sh ? "sh"
                                                                       : "none"));
  s.set("shading", std::string(render::shading_name(renderer_.shading())));
  s.set("material", material_name_);
  s.set("model_materials", double(model_materials_.size()));
  val warnings = val::array();
  for (const std::string& w : model_warnings_) warnings.call<void>("push", w);
  s.set("model_warnings", warnings);
  s.set("refraction", std::string(render::refraction_name(renderer_.refraction())));
  s.set("colour", std::string(render::colour_correction_name(colour_)));
  s.set("sun", std::string(sun_state_name(l.sun_state)));
  s.set("sun_direction", vector_to_js(l.sun_direction));
  s.set("last_error", last_error_);
  s.set("moved_to", state_.moved_to());  // a Moved error's web port (issue 49 §2)
  // Two phones, one room (issue 49 §1): this page's frames against the session's map (0 its own
  // session, 1 waiting to be registered, 2 registered), and the token another phone joins with.
  s.set("joining", !join_.empty());
  s.set("registration", update ? int(update->registration) : 0);
  const auto& join = state_.join_token();
  s.set("join_token", join ? join->token : std::string());
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

val WebClient::object_pixel() const { return pixel_of({0.0, 0.0, 0.5 * object_height_}); }

val WebClient::floor_pixel() const {
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

val WebClient::view() const {
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

// A scene point's pixel in the last composite, or null when it is behind the camera or nothing
// was drawn yet.
val WebClient::pixel_of(const glm::dvec3& scene_point) const {
  if (!last_camera_from_scene_) return val::null();
  const glm::dvec3 c = *last_camera_from_scene_ * glm::dvec4(scene_point, 1.0);
  if (c.z >= -1e-3) return val::null();  // looking down -z
  val p = val::array();
  p.call<void>("push", camera_.cx + camera_.fx * (c.x / -c.z));
  p.call<void>("push", camera_.cy - camera_.fy * (c.y / -c.z));
  return p;
}

}  // namespace arlight::web
