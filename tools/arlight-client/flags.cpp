#include "flags.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <tuple>

#include "arlight/common/error.hpp"
#include "arlight/common/geo.hpp"
#include "arlight/common/number_list.hpp"
#include "arlight/truth/truth.hpp"
#include "report.hpp"

namespace arlight::client_app {

void add_client_flags(CLI::App& app, ClientFlags& f) {
  app.add_option("--server", f.server, "arlightd HOST:PORT")->required();
  app.add_option("--token", f.token, "this device's token")->required();
  app.add_option("--source", f.source_spec,
                 "v4l2:/dev/videoN, replay:RECORDING or sim:PROBE.exr (a simulated phone "
                 "sweeping that room, rendered as it goes; follows arlightd's exposure advice)")
      ->required();
  app.add_option("--model", f.model, "glTF 2.0 model (.glb/.gltf, Draco ok) or 'sphere'")
      ->capture_default_str();
  app.add_option("--material", f.material_text,
                 "kd,ks,shininess (Phong), pbr:R,G,B,METALLIC,ROUGHNESS (glTF metallic-"
                 "roughness) or model (the glTF's own materials; Phong's default where a part "
                 "has none)")
      ->capture_default_str();
  app.add_option("--ggx", f.ggx_face,
                 "request the room's GGX chain from this face instead of --maps (default: 256 "
                 "with a pbr: material, else none; 0: none)");
  app.add_option("--ggx-lights", f.ggx_lights,
                 "with --ggx: up to this many small, bright lights taken out of the chain and "
                 "shaded with the full BRDF (0: the chain holds the whole room; not with --out)")
      ->capture_default_str()->check(CLI::Range(0, kMaxSpecularLights));
  app.add_option("--marker", f.marker_text, "ArUco DICT_4X4_50 marker ID,SIZE_M")
      ->capture_default_str();
  app.add_option("--object-height", f.object_height,
                 "height of the virtual object in metres (default 1.5 x the marker)");
  app.add_option("--normal-map", f.normal_map, "tangent-space normal map image (needs uvs)");
  app.add_option("--light-map", f.light_map, "light map image (multiplies diffuse irradiance)");
  app.add_option("--shadow", f.shadow,
                 "on: the object casts shadows on the real floor (the marker's plane): soft "
                 "shadows from the room's lights (or the dominant light's, before maps) plus a "
                 "contact shadow, darkening the frame there")
      ->check(CLI::IsMember({"on", "off"}))
      ->capture_default_str();
  app.add_option("--shadow-lights", f.shadow_lights,
                 "at most this many hard shadows blended into the soft one under a map set (the "
                 "clusters of the room's brightest light, tutorial §6), 1-32")
      ->capture_default_str();
  app.add_option("--target-fps", f.target_fps,
                 "frame-rate control (tutorial §6.4): as many shadow lights as keep the client's "
                 "own work per frame within 1/F s; 0: always --shadow-lights")
      ->capture_default_str();
  app.add_option("--shading", f.shading,
                 "maps (irradiance and reflection maps), hemisphere (two colours from the "
                 "room's upper and lower half, blended by the normal: the fallback for weak "
                 "devices) or hemisphere-occlusion (that, darker towards the ground by the "
                 "room's dark side over its lit side)")
      ->capture_default_str();
  app.add_option("--occlusion", f.occlusion,
                 "baked (the model's occlusion of itself and of the floor, ray-cast with Embree "
                 "at load: its creases get less of the room's light, from the directions left "
                 "open, and its contact shadow follows its shape) or none (the contact shadow "
                 "of the ellipsoid in its bounds)")
      ->check(CLI::IsMember({"baked", "none"}))
      ->capture_default_str();
  app.add_option("--glass", f.glass,
                 "off (the --material), or the object is clear glass (dissertation §5.5): "
                 "reflection and refraction split by the Fresnel term, refracted at both of "
                 "its surfaces, showing the room's maps (maps) or the camera frame behind it "
                 "(live: what is there now, a person walking past too) through it")
      ->capture_default_str();
  app.add_option("--ior", f.ior, "the glass's index of refraction (water 1.33, diamond 2.42)")
      ->capture_default_str();
  app.add_option("--location", f.location,
                 "LAT,LON[,ALT]: where the camera is (degrees, degrees, metres), so arlightd "
                 "knows where the sun is (it reports it, and uses it for the dominant light "
                 "and the shadows once the captured map shows it there); a replay: the "
                 "recording's place, if it has one");
  app.add_option("--time", f.time_text,
                 "UTC time of the frames, YYYY-MM-DDTHH:MM[:SS]Z, with --location (default: "
                 "now)");
  app.add_option("--north-offset", f.north_offset,
                 "the frames' world -Z is north, this many degrees east of true north (a "
                 "compass: its magnetic declination); without it the heading is taken as "
                 "arbitrary and arlightd measures it from the sun");
  app.add_option("--out", f.out, "folder for composited frames (PNG), contact sheet, MP4");
  app.add_flag("--window", f.window, "show the frames in a window (needs $DISPLAY)");
  app.add_option("--json", f.json_path, "write the summary (frames, timings, pose error) here");
  app.add_option("--device", f.device, "device id (default: the source's)");
  app.add_option("--resume", f.resume, "continue this arlightd session");
  app.add_option("--tone", f.tone,
                 "camera (matched to the frame), reinhard or linear; then optionally "
                 ",brightness, ,contrast or ,match: the dissertation's colour correction "
                 "against the room's colour priors (e.g. camera,match)")
      ->capture_default_str();
  app.add_option("--response", f.response, "camera response: srgb, filmic or a JSON curve")
      ->capture_default_str();
  app.add_option("--maps", f.maps_text, "shininess values of the map set to request ('' none)")
      ->capture_default_str();
  app.add_option("--map-size", f.map_size, "size of the requested maps")->capture_default_str();
  app.add_option("--wait-maps", f.wait_maps_s,
                 "seconds to wait for a map set before the first frame (0: shade with SH)");
  app.add_flag("--realtime", f.realtime,
               "replay at the recording's pace (default: as fast as it can)");
  app.add_option("--frames", f.frames_limit,
                 "stop after this many frames (0: all; a sim: source sweeps the room in this "
                 "many, 300 when 0)");
  app.add_flag("--guided", f.guided,
               "a sim: source's user turns to the views arlightd asks for (LightingUpdate."
               "next_view) instead of sweeping the room");
  app.add_option("--size", f.size, "camera size WIDTHxHEIGHT of v4l2: (asked for) and sim: sources")
      ->capture_default_str();
  app.add_option("--pose", f.pose,
                 "draw the object where the marker tracker puts it (track) or, replaying a "
                 "simulated recording, where its ground truth does (truth: scores the lighting "
                 "alone, arlight-eval)")
      ->capture_default_str();
  app.add_option("--fps", f.fps,
                 "frame rate asked of a v4l2: source, and of a sim: source's simulated camera")
      ->capture_default_str();
  app.add_option("--intrinsics", f.intrinsics_file, "webcam calibration (OpenCV YAML/JSON)");
  app.add_flag("--tls", f.tls.enabled, "connect with TLS (trusting the system's CAs)");
  app.add_option("--tls-ca", f.tls.ca_file, "connect with TLS, trusting this PEM CA/certificate");
}

std::unique_ptr<source::FrameSource> open_client_source(const ClientFlags& f) {
  source::SourceOptions so;
  so.realtime = f.realtime, so.intrinsics_file = f.intrinsics_file;
  const ImageSize image = parse_image_size(f.size, "--size");
  so.width = image.width, so.height = image.height;
  so.fps = f.fps;
  if (f.frames_limit > 0) so.frames = f.frames_limit;
  so.guided = f.guided;
  std::unique_ptr<source::FrameSource> src = source::open_source(f.source_spec, so);
  spdlog::info("source: {}", src->describe());
  return src;
}

PipelineOptions pipeline_options(const ClientFlags& f, const source::FrameSource& src,
                                 const std::vector<double>& shininess) {
  PipelineOptions po;
  po.marker = parse_marker(f.marker_text);
  po.material = parse_material(f.material_text);
  po.object_height = f.object_height;
  po.shadow = f.shadow == "on";
  po.shadow_lights = f.shadow_lights;
  po.target_fps = f.target_fps;
  std::tie(po.tone, po.colour) = parse_tone_options(f.tone);
  po.shading = parse_shading(f.shading);
  po.response = CameraResponse::named(f.response);
  if (const auto refraction = parse_glass(f.glass)) {
    // As sharp as the sharpest reflection map asked for.
    po.material = glass_material(
        f.ior, shininess.empty() ? 1280.0 : *std::max_element(shininess.begin(), shininess.end()));
    po.refraction = *refraction;
  }
  po.camera = src.intrinsics();
  std::optional<recording::Truth> truth;
  if (const auto* replay = dynamic_cast<const source::ReplaySource*>(&src))
    truth = recording::read_truth(replay->recording().folder);
  po.true_pose = true_poses(truth);
  if (f.pose != "track" && f.pose != "truth")
    throw InputError("--pose '" + f.pose + "': use track or truth");
  po.draw_at_true_pose = f.pose == "truth";
  if (po.draw_at_true_pose && !po.true_pose)
    throw InputError("--pose truth: needs a replay of a simulated recording with a marker");
  if (po.draw_at_true_pose) po.true_world_from_marker = truth->marker->pose.orientation;
  return po;
}

ClientObject load_client_object(const ClientFlags& f, render::Material& material) {
  if (!f.normal_map.empty()) material.normal_map = render::load_texture(f.normal_map, false);
  if (!f.light_map.empty()) material.light_map = render::load_texture(f.light_map, false);
  ClientObject object;
  if (f.material_text == "model") {
    render::GltfModel model = load_model_with_materials(f.model);
    object.mesh = std::move(model.mesh), object.materials = std::move(model.materials);
    if (object.materials.empty()) spdlog::warn("{}: --material model, but it has no materials", f.model);
  } else {
    object.mesh = load_model(f.model);
  }
  if (f.occlusion == "none") {
    object.mesh.occlusion.clear(), object.mesh.transfer.clear(), object.mesh.ground = {};
    return object;
  }
  BakedModel baked = bake_model(std::move(object.mesh), default_bake_cache());
  object.mesh = std::move(baked.mesh), object.occlusion_state = baked.state;
  object.bake_ms = baked.bake_ms;
  spdlog::info("{}: occlusion {} for {} vertices in {:.0f} ms", f.model, object.occlusion_state,
               object.mesh.vertex_count(), object.bake_ms);
  return object;
}

LinkOptions link_options(const ClientFlags& f, source::FrameSource& src,
                         const CameraIntrinsics& camera, const std::vector<double>& shininess) {
  LinkOptions lo;
  wire::parse_endpoint(f.server, lo.host, lo.port);
  lo.token = f.token, lo.tls = f.tls, lo.resume_session = f.resume;
  lo.device_id = !f.device.empty()          ? f.device
                 : !src.device_id().empty() ? src.device_id()
                                            : "webcam";
  lo.camera = camera, lo.shininess = shininess, lo.map_size = f.map_size;
  const bool pbr = f.material_text.rfind("pbr:", 0) == 0 || f.material_text == "model";
  lo.ggx_face = f.ggx_face >= 0 ? f.ggx_face : pbr ? 256 : 0;
  lo.ggx_lights = f.ggx_lights;
  // The light files --out writes are engines' whole room: a chain without its lights is not.
  if (lo.ggx_face > 0 && lo.ggx_lights > 0 && !f.out.empty())
    throw InputError("--ggx-lights " + std::to_string(lo.ggx_lights) +
                     ": the light files --out writes need the chain of the whole room; ask for "
                     "--ggx-lights 0 to write them");
  lo.exposure_advice = src.request_exposure(0.0);  // (0 asks nothing: can it at all?)
  lo.max_in_flight = src.live() ? 2 : 0;  // a replay as fast as possible sends every frame
  if (!f.location.empty()) {
    if (f.north_offset && !(std::abs(*f.north_offset) <= 180.0))
      throw InputError("--north-offset: must be in [-180, 180] degrees");
    lo.location = client::make_location(
        parse_geo_location(f.location, "--location"),
        !f.time_text.empty()
            ? parse_utc_time(f.time_text, "--time")
            : std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch())
                  .count(),
        f.north_offset);
  } else if (!f.time_text.empty() || f.north_offset) {
    throw InputError("--time and --north-offset need --location");
  } else if (const auto* replay = dynamic_cast<const source::ReplaySource*>(&src);
             replay && replay->recording().place) {
    // A recording that says where and when it was made (RECORDING.md "place").
    const recording::Recording& rec = replay->recording();
    const recording::RecordedPlace& p = *rec.place;
    lo.location = client::make_location(
        p.where, p.utc_seconds + (rec.frames.empty() ? 0.0 : rec.frames.front().timestamp),
        p.north_offset_deg);
    spdlog::info("the recording was made at {:.5f}, {:.5f}: telling arlightd (the sun)",
                 p.where.latitude_deg, p.where.longitude_deg);
  }
  return lo;
}

}  // namespace arlight::client_app
