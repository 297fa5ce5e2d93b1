// arlight-client: the thin AR client. Parses its flags, builds the per-frame pipeline
// (client/app: tracking, the link to arlightd, rendering, tone mapping, compositing), runs it
// over a webcam or a recording, and reports.
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cstdio>
#include <tuple>

#include "arlight/client_app.hpp"
#include "arlight/error.hpp"
#include "arlight/geo.hpp"
#include "arlight/number_list.hpp"
#include "arlight/sim_source.hpp"
#include "report.hpp"

using namespace arlight;
using namespace arlight::client_app;
using Clock = std::chrono::steady_clock;

namespace {

// What arlightd said of the sun last (with --location).
nlohmann::json sun_json(const Lighting& l) {
  nlohmann::json j = {{"state", sun_state_name(l.sun_state)}};
  if (l.sun_state != SunState::Unknown)
    j["direction"] = {l.sun_direction.x, l.sun_direction.y, l.sun_direction.z};
  return j;
}

}  // namespace

int main(int argc, char** argv) {
  spdlog::set_default_logger(spdlog::stderr_color_mt("arlight-client"));
  source::register_sim_source();  // --source sim:PROBE.exr (the laboratory's simulated phone)
  CLI::App app{
      "arlight-client: tracks a marker, lights a virtual object with arlightd's "
      "lighting and composites it into the camera frames"};
  std::string server, token, source_spec,
      model = "sphere", material_text = "0.8,0.2,80", marker_text = "0,0.2", out, json_path, device,
      resume, tone = "camera", response = "srgb", maps_text = "1,10,20,40,80,160,320,1280",
      intrinsics_file, normal_map, light_map, shadow = "on", size = "640x480", shading = "maps",
      location, time_text, glass = "off", pose = "track", occlusion = "baked";
  std::optional<double> north_offset;
  bool window = false, realtime = false;
  int frames_limit = 0, map_size = 128, shadow_lights = 16;
  double object_height = 0, wait_maps_s = 0, ior = 1.5, fps = 30, target_fps = 30;
  client::TlsOptions tls;
  app.add_option("--server", server, "arlightd HOST:PORT")->required();
  app.add_option("--token", token, "this device's token")->required();
  app.add_option("--source", source_spec,
                 "v4l2:/dev/videoN, replay:RECORDING or sim:PROBE.exr (a simulated phone "
                 "sweeping that room, rendered as it goes; follows arlightd's exposure advice)")
      ->required();
  app.add_option("--model", model, "glTF 2.0 model (.glb/.gltf, Draco ok) or 'sphere'")
      ->capture_default_str();
  app.add_option("--material", material_text, "kd,ks,shininess (Phong)")->capture_default_str();
  app.add_option("--marker", marker_text, "ArUco DICT_4X4_50 marker ID,SIZE_M")
      ->capture_default_str();
  app.add_option("--object-height", object_height,
                 "height of the virtual object in metres (default 1.5 x the marker)");
  app.add_option("--normal-map", normal_map, "tangent-space normal map image (needs uvs)");
  app.add_option("--light-map", light_map, "light map image (multiplies diffuse irradiance)");
  app.add_option("--shadow", shadow,
                 "on: the object casts shadows on the real floor (the marker's plane): soft "
                 "shadows from the room's lights (or the dominant light's, before maps) plus a "
                 "contact shadow, darkening the frame there")
      ->check(CLI::IsMember({"on", "off"}))
      ->capture_default_str();
  app.add_option("--shadow-lights", shadow_lights,
                 "at most this many hard shadows blended into the soft one under a map set (the "
                 "clusters of the room's brightest light, tutorial §6), 1-32")
      ->capture_default_str();
  app.add_option("--target-fps", target_fps,
                 "frame-rate control (tutorial §6.4): as many shadow lights as keep the client's "
                 "own work per frame within 1/F s; 0: always --shadow-lights")
      ->capture_default_str();
  app.add_option("--shading", shading,
                 "maps (irradiance and reflection maps), hemisphere (two colours from the "
                 "room's upper and lower half, blended by the normal: the fallback for weak "
                 "devices) or hemisphere-occlusion (that, darker towards the ground by the "
                 "room's dark side over its lit side)")
      ->capture_default_str();
  app.add_option("--occlusion", occlusion,
                 "baked (the model's occlusion of itself and of the floor, ray-cast with Embree "
                 "at load: its creases get less of the room's light, from the directions left "
                 "open, and its contact shadow follows its shape) or none (the contact shadow "
                 "of the ellipsoid in its bounds)")
      ->check(CLI::IsMember({"baked", "none"}))
      ->capture_default_str();
  app.add_option("--glass", glass,
                 "off (the --material), or the object is clear glass (dissertation §5.5): "
                 "reflection and refraction split by the Fresnel term, refracted at both of "
                 "its surfaces, showing the room's maps (maps) or the camera frame behind it "
                 "(live: what is there now, a person walking past too) through it")
      ->capture_default_str();
  app.add_option("--ior", ior, "the glass's index of refraction (water 1.33, diamond 2.42)")
      ->capture_default_str();
  app.add_option("--location", location,
                 "LAT,LON[,ALT]: where the camera is (degrees, degrees, metres), so arlightd "
                 "knows where the sun is (it reports it, and uses it for the dominant light "
                 "and the shadows once the captured map shows it there); a replay: the "
                 "recording's place, if it has one");
  app.add_option("--time", time_text,
                 "UTC time of the frames, YYYY-MM-DDTHH:MM[:SS]Z, with --location (default: "
                 "now)");
  app.add_option("--north-offset", north_offset,
                 "the frames' world -Z is north, this many degrees east of true north (a "
                 "compass: its magnetic declination); without it the heading is taken as "
                 "arbitrary and arlightd measures it from the sun");
  app.add_option("--out", out, "folder for composited frames (PNG), contact sheet, MP4");
  app.add_flag("--window", window, "show the frames in a window (needs $DISPLAY)");
  app.add_option("--json", json_path, "write the summary (frames, timings, pose error) here");
  app.add_option("--device", device, "device id (default: the source's)");
  app.add_option("--resume", resume, "continue this arlightd session");
  app.add_option("--tone", tone,
                 "camera (matched to the frame), reinhard or linear; then optionally "
                 ",brightness, ,contrast or ,match: the dissertation's colour correction "
                 "against the room's colour priors (e.g. camera,match)")
      ->capture_default_str();
  app.add_option("--response", response, "camera response: srgb, filmic or a JSON curve")
      ->capture_default_str();
  app.add_option("--maps", maps_text, "shininess values of the map set to request ('' none)")
      ->capture_default_str();
  app.add_option("--map-size", map_size, "size of the requested maps")->capture_default_str();
  app.add_option("--wait-maps", wait_maps_s,
                 "seconds to wait for a map set before the first frame (0: shade with SH)");
  app.add_flag("--realtime", realtime,
               "replay at the recording's pace (default: as fast as it can)");
  app.add_option("--frames", frames_limit,
                 "stop after this many frames (0: all; a sim: source sweeps the room in this "
                 "many, 300 when 0)");
  app.add_option("--size", size, "camera size WIDTHxHEIGHT of v4l2: (asked for) and sim: sources")
      ->capture_default_str();
  app.add_option("--pose", pose,
                 "draw the object where the marker tracker puts it (track) or, replaying a "
                 "simulated recording, where its ground truth does (truth: scores the lighting "
                 "alone, arlight-eval)")
      ->capture_default_str();
  app.add_option("--fps", fps,
                 "frame rate asked of a v4l2: source, and of a sim: source's simulated camera")
      ->capture_default_str();
  app.add_option("--intrinsics", intrinsics_file, "webcam calibration (OpenCV YAML/JSON)");
  app.add_flag("--tls", tls.enabled, "connect with TLS (trusting the system's CAs)");
  app.add_option("--tls-ca", tls.ca_file, "connect with TLS, trusting this PEM CA/certificate");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  try {
    // ---- construct: source, pipeline, link ----
    LinkOptions lo;
    wire::parse_endpoint(server, lo.host, lo.port);
    PipelineOptions po;
    po.marker = parse_marker(marker_text);
    po.material = parse_material(material_text);
    po.object_height = object_height;
    po.shadow = shadow == "on";
    po.shadow_lights = shadow_lights;
    po.target_fps = target_fps;
    std::tie(po.tone, po.colour) = parse_tone_options(tone);
    po.shading = parse_shading(shading);
    po.response = CameraResponse::named(response);
    const std::vector<double> shininess = parse_number_list(maps_text, "--maps");
    if (const auto refraction = parse_glass(glass)) {
      // As sharp as the sharpest reflection map asked for.
      po.material = glass_material(
          ior, shininess.empty() ? 1280.0 : *std::max_element(shininess.begin(), shininess.end()));
      po.refraction = *refraction;
    }
    source::SourceOptions so;
    so.realtime = realtime, so.intrinsics_file = intrinsics_file;
    const ImageSize image = parse_image_size(size, "--size");
    so.width = image.width, so.height = image.height;
    so.fps = fps;
    if (frames_limit > 0) so.frames = frames_limit;
    std::unique_ptr<source::FrameSource> src = source::open_source(source_spec, so);
    po.camera = src->intrinsics();
    spdlog::info("source: {}", src->describe());
    std::optional<recording::Truth> truth;
    if (const auto* replay = dynamic_cast<source::ReplaySource*>(src.get()))
      truth = recording::read_truth(replay->recording().folder);
    po.true_pose = true_poses(truth);
    if (pose != "track" && pose != "truth")
      throw InputError("--pose '" + pose + "': use track or truth");
    po.draw_at_true_pose = pose == "truth";
    if (po.draw_at_true_pose && !po.true_pose)
      throw InputError("--pose truth: needs a replay of a simulated recording with a marker");
    if (po.draw_at_true_pose) po.true_world_from_marker = truth->marker->pose.orientation;
    render::GlContext gl =
        window ? render::GlContext::window(po.camera.width, po.camera.height, "arlight-client")
               : render::GlContext::headless();
    spdlog::info("GL: {} ({})", gl.renderer(), gl.version());
    if (!normal_map.empty()) po.material.normal_map = render::load_texture(normal_map, false);
    if (!light_map.empty()) po.material.light_map = render::load_texture(light_map, false);
    render::Mesh mesh = load_model(model);
    std::string occlusion_state = "none";
    double bake_ms = 0;
    if (occlusion == "none") {
      mesh.occlusion.clear(), mesh.transfer.clear(), mesh.ground = {};
    } else {
      BakedModel baked = bake_model(std::move(mesh), default_bake_cache());
      mesh = std::move(baked.mesh), occlusion_state = baked.state, bake_ms = baked.bake_ms;
      spdlog::info("{}: occlusion {} for {} vertices in {:.0f} ms", model, occlusion_state,
                   mesh.vertex_count(), bake_ms);
    }
    FramePipeline pipeline(po, std::move(mesh));

    lo.token = token, lo.tls = tls, lo.resume_session = resume;
    lo.device_id = !device.empty()             ? device
                   : !src->device_id().empty() ? src->device_id()
                                               : "webcam";
    lo.camera = po.camera, lo.shininess = shininess, lo.map_size = map_size;
    lo.exposure_advice = src->request_exposure(0.0);  // (0 asks nothing: can it at all?)
    if (!location.empty()) {
      if (north_offset && !(std::abs(*north_offset) <= 180.0))
        throw InputError("--north-offset: must be in [-180, 180] degrees");
      lo.location = client::make_location(
          parse_geo_location(location, "--location"),
          !time_text.empty()
              ? parse_utc_time(time_text, "--time")
              : std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch())
                    .count(),
          north_offset);
    } else if (!time_text.empty() || north_offset) {
      throw InputError("--time and --north-offset need --location");
    } else if (const auto* replay = dynamic_cast<source::ReplaySource*>(src.get());
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
    LightingLink link(lo);
    link.wait_connected(std::chrono::seconds(10));
    if (wait_maps_s > 0 && !shininess.empty())
      link.wait_for_maps(std::chrono::duration<double>(wait_maps_s));
    LinkChannel channel(link);

    // ---- loop ----
    RunOutput output(out, json_path);
    RunStats stats;
    cv::Mat composited;
    while (frames_limit <= 0 || int(stats.frames) < frames_limit) {
      const auto t0 = Clock::now();
      // arlightd asked for a darker frame (its exposure advice): the next one, where the
      // source can.
      if (const auto advice = link.take_exposure_advice()) src->request_exposure(*advice);
      std::optional<source::SourceFrame> f = src->next();
      if (!f) break;
      const double decode_ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
      const FrameReport r = pipeline.process(*f, channel, composited);
      stats.add(r, decode_ms);
      if (window) pipeline.renderer().present(), gl.swap_buffers();
      output.add(r, composited);
    }

    // ---- report ----
    output.finish(stats, link.stats(),
                  {{"renderer", gl.renderer()},
                   {"size", {po.camera.width, po.camera.height}},
                   {"shading", render::shading_name(po.shading)},
                   {"glass", glass},
                   {"occlusion", {{"state", occlusion_state}, {"bake_ms", bake_ms}}},
                   {"colour", render::colour_correction_name(po.colour)},
                   {"ior", ior},
                   {"sun", sun_json(channel.lighting())}});
    return stats.frames > 0 ? 0 : 1;
  } catch (const InputError& e) {
    std::fprintf(stderr, "arlight-client: bad input: %s\n", e.what());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "arlight-client: error: %s\n", e.what());
    return 1;
  }
}
