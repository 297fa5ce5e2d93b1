// arlight-client: the thin AR client. Frames from a webcam or a recording go to arlightd (with
// the device's orientation) while the client tracks the marker, shades a virtual object with
// the lighting arlightd sends back (live SH, then irradiance and reflection maps), tone maps it
// like the camera and composites it into the frame (thesis ch. 5, tutorial §4.1).
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <glm/gtc/matrix_transform.hpp>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "arlight/atomic_file.hpp"
#include "arlight/error.hpp"
#include "arlight/number_list.hpp"
#include "arlight/render.hpp"
#include "arlight/source.hpp"
#include "arlight/track.hpp"
#include "arlight/truth.hpp"
#include "arlight/wire.hpp"
#include "lighting_link.hpp"

namespace fs = std::filesystem;
using namespace arlight;
using Clock = std::chrono::steady_clock;
using json = nlohmann::json;

namespace {

double ms_since(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

double median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, std::size_t(p * double(v.size() - 1) + 0.5))];
}

render::ToneMode parse_tone(const std::string& name) {
  if (name == "camera") return render::ToneMode::CameraMatched;
  if (name == "reinhard") return render::ToneMode::Reinhard;
  if (name == "linear") return render::ToneMode::Linear;
  throw InputError("--tone: '" + name + "' is not camera, reinhard or linear");
}

// A few frames side by side: what the demo shows at a glance.
void write_contact_sheet(const std::vector<cv::Mat>& frames, const fs::path& path) {
  if (frames.empty()) return;
  const int cols = std::min<int>(4, int(frames.size()));
  const int rows = (int(frames.size()) + cols - 1) / cols;
  const int w = 320, h = frames[0].rows * w / frames[0].cols;
  cv::Mat sheet(rows * h, cols * w, CV_8UC3, cv::Scalar(0, 0, 0));
  for (std::size_t i = 0; i < frames.size(); ++i) {
    cv::Mat small;
    cv::resize(frames[i], small, cv::Size(w, h), 0, 0, cv::INTER_AREA);
    small.copyTo(sheet(cv::Rect(int(i) % cols * w, int(i) / cols * h, w, h)));
  }
  std::vector<std::uint8_t> png;
  cv::imencode(".png", sheet, png);
  write_file_atomically(path,
                        std::string_view(reinterpret_cast<const char*>(png.data()), png.size()));
}

}  // namespace

int main(int argc, char** argv) {
  spdlog::set_default_logger(spdlog::stderr_color_mt("arlight-client"));
  CLI::App app{
      "arlight-client: tracks a marker, lights a virtual object with arlightd's lighting and "
      "composites it into the camera frames"};
  std::string server, token, source_spec,
      model = "sphere", material_text = "0.8,0.2,80", marker_text = "0,0.2", out, json_path, device,
      resume, tone_name = "camera", response_name = "srgb",
      maps_text = "1,10,20,40,80,160,320,1280", intrinsics_file, normal_map, light_map,
      shadow_mode = "on";
  bool window = false, realtime = false;
  int frames_limit = 0, map_size = 128;
  double object_height = 0, wait_maps_s = 0;
  client::TlsOptions tls;
  app.add_option("--server", server, "arlightd HOST:PORT")->required();
  app.add_option("--token", token, "this device's token")->required();
  app.add_option("--source", source_spec, "v4l2:/dev/videoN or replay:RECORDING")->required();
  app.add_option("--model", model, "glTF 2.0 model (.glb/.gltf, Draco ok) or 'sphere'")
      ->capture_default_str();
  app.add_option("--material", material_text, "kd,ks,shininess (Phong)")->capture_default_str();
  app.add_option("--marker", marker_text, "ArUco DICT_4X4_50 marker ID,SIZE_M")
      ->capture_default_str();
  app.add_option("--object-height", object_height,
                 "height of the virtual object in metres (default 1.5 x the marker)");
  app.add_option("--normal-map", normal_map, "tangent-space normal map image (needs uvs)");
  app.add_option("--light-map", light_map, "light map image (multiplies diffuse irradiance)");
  app.add_option("--shadow", shadow_mode,
                 "on: the object casts shadows on the real floor (the marker's plane): the "
                 "dominant light's shadow map plus a contact shadow, darkening the frame there")
      ->check(CLI::IsMember({"on", "off"}))
      ->capture_default_str();
  app.add_option("--out", out, "folder for composited frames (PNG), contact sheet, MP4");
  app.add_flag("--window", window, "show the frames in a window (needs $DISPLAY)");
  app.add_option("--json", json_path, "write the summary (frames, timings, pose error) here");
  app.add_option("--device", device, "device id (default: the source's)");
  app.add_option("--resume", resume, "continue this arlightd session");
  app.add_option("--tone", tone_name, "camera (matched to the frame), reinhard or linear")
      ->capture_default_str();
  app.add_option("--response", response_name, "camera response: srgb, filmic or a JSON curve")
      ->capture_default_str();
  app.add_option("--maps", maps_text, "shininess values of the map set to request ('' none)")
      ->capture_default_str();
  app.add_option("--map-size", map_size, "size of the requested maps")->capture_default_str();
  app.add_option("--wait-maps", wait_maps_s,
                 "seconds to wait for a map set before the first frame (0: shade with SH)");
  app.add_flag("--realtime", realtime,
               "replay at the recording's pace (default: as fast as it can)");
  app.add_option("--frames", frames_limit, "stop after this many frames (0: all)");
  app.add_option("--intrinsics", intrinsics_file, "webcam calibration (OpenCV YAML/JSON)");
  app.add_flag("--tls", tls.enabled, "connect with TLS (trusting the system's CAs)");
  app.add_option("--tls-ca", tls.ca_file, "connect with TLS, trusting this PEM CA/certificate");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  try {
    // ---- settings ----
    std::string host;
    std::uint16_t port = 0;
    wire::parse_endpoint(server, host, port);
    const std::vector<double> mat = parse_number_list(material_text, "--material");
    if (mat.size() != 3 || mat[0] < 0 || mat[1] < 0 || !(mat[2] >= 1))
      throw InputError("--material: kd,ks,s with kd, ks >= 0 and s >= 1");
    const std::vector<double> mk = parse_number_list(marker_text, "--marker");
    if (mk.size() != 2 || !(mk[1] > 0) || mk[0] < 0 || mk[0] != std::floor(mk[0]))
      throw InputError("--marker: ID,SIZE_M with an integer ID and a size > 0");
    const track::MarkerSpec marker{"DICT_4X4_50", int(mk[0]), mk[1]};
    if (object_height <= 0) object_height = 1.5 * marker.size_m;
    const render::ToneMode tone_mode = parse_tone(tone_name);
    const std::vector<double> shininess = parse_number_list(maps_text, "--maps");

    source::SourceOptions so;
    so.realtime = realtime;
    so.intrinsics_file = intrinsics_file;
    std::unique_ptr<source::FrameSource> src = source::open_source(source_spec, so);
    const CameraIntrinsics camera = src->intrinsics();
    spdlog::info("source: {}", src->describe());
    std::optional<recording::Truth> truth;
    if (const auto* replay = dynamic_cast<source::ReplaySource*>(src.get()))
      truth = recording::read_truth(replay->recording().folder);

    // ---- renderer ----
    render::GlContext gl =
        window ? render::GlContext::window(camera.width, camera.height, "arlight-client")
               : render::GlContext::headless();
    spdlog::info("GL: {} ({})", gl.renderer(), gl.version());
    render::Renderer renderer(camera.width, camera.height);
    renderer.set_response(CameraResponse::named(response_name));
    // The virtual object, standing on the marker.
    const render::Mesh mesh =
        model == "sphere" ? render::make_sphere(0.5f, 64, 128) : render::load_gltf(model);
    if (mesh.positions.empty()) throw InputError(model + ": no triangles");
    const glm::mat4 model_matrix = render::standing_on_marker(mesh.bounds, float(object_height));
    render::Material material;
    material.kd = glm::vec3(float(mat[0]));
    material.ks = glm::vec3(float(mat[1]));
    material.shininess = float(mat[2]);
    if (!normal_map.empty()) material.normal_map = render::load_texture(normal_map, false);
    if (!light_map.empty()) material.light_map = render::load_texture(light_map, false);
    const render::GpuMesh gpu_mesh(mesh);

    // ---- tracking and orientation ----
    track::MarkerTracker tracker(camera, marker);
    track::WorldFromMarker world_from_marker;
    track::OrientationEstimator webcam_orientation(camera);

    // ---- the link to arlightd ----
    client_app::LinkOptions lo;
    lo.host = host, lo.port = port, lo.token = token, lo.tls = tls;
    lo.device_id = device.empty() ? src->device_id() : device;
    if (lo.device_id.empty()) lo.device_id = "webcam";
    lo.resume_session = resume;
    lo.camera = camera;
    lo.shininess = shininess;
    lo.map_size = map_size;
    client_app::LightingLink link(lo);
    link.wait_connected(std::chrono::seconds(10));
    if (wait_maps_s > 0 && !shininess.empty()) {
      const auto end = Clock::now() + std::chrono::duration<double>(wait_maps_s);
      while (!link.lighting().maps && Clock::now() < end)
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }

    if (!out.empty()) fs::create_directories(fs::path(out) / "frames");
    render::ToneMapping tone;
    tone.mode = tone_mode;
    std::uint64_t sh_version = 0, maps_version = 0;
    std::vector<double> frame_ms, track_ms, render_ms, tonemap_ms, decode_ms, err_cm, err_deg;
    std::vector<cv::Mat> sheet;
    std::size_t frames = 0, tracked = 0, written = 0;
    std::size_t lit_by_maps = 0, lit_by_sh = 0;
    cv::Mat composited;
    std::optional<track::Pose> last_pose;  // smoothed, for frames right after a loss
    double last_pose_time = -1;

    for (;;) {
      if (frames_limit > 0 && int(frames) >= frames_limit) break;
      auto t0 = Clock::now();
      std::optional<source::SourceFrame> f = src->next();
      if (!f) break;
      decode_ms.push_back(ms_since(t0));
      ++frames;

      // Tracking, then the orientation that goes to arlightd and the lighting's rotation.
      auto t1 = Clock::now();
      const track::TrackResult tr = tracker.track(f->bgr, f->timestamp);
      std::optional<glm::dquat> world_from_camera = f->orientation;
      std::optional<glm::dquat> world_from_scene;
      if (world_from_camera) {  // a phone: IMU orientation; the marker's rotation estimated
        if (tr.tracked) world_from_marker.add(f->timestamp, *world_from_camera, tr.raw.orientation);
        world_from_scene = world_from_marker.world_from_marker();
      } else {  // a webcam: the world is defined by the marker, the visual gyro in between
        const track::OrientationEstimate est = webcam_orientation.update(f->bgr, f->timestamp, &tr);
        world_from_camera = est.orientation;
        world_from_scene = track::webcam_world_from_marker();
      }
      if (tr.tracked) {
        ++tracked;
        last_pose = tr.smoothed;
        last_pose_time = f->timestamp;
      }
      track_ms.push_back(ms_since(t1));

      // To arlightd: the frame with its orientation (none yet: a webcam before the marker).
      if (world_from_camera) {
        std::vector<std::uint8_t> encoded;
        if (f->jpeg.empty()) cv::imencode(".jpg", f->bgr, encoded, {cv::IMWRITE_JPEG_QUALITY, 90});
        const double exposure = f->exposure > 0 ? f->exposure : 1.0 / 30;
        link.send_frame(f->index + 1, {f->timestamp, exposure, f->gain, *world_from_camera},
                        f->bgr.cols, f->bgr.rows, f->jpeg.empty() ? encoded : f->jpeg);
      }

      // Lighting: the newest map set once there is one, the live SH before.
      const client_app::Lighting lighting = link.lighting();
      if (lighting.maps && lighting.maps_version != maps_version) {
        renderer.set_maps(lighting.maps->shininess, lighting.maps->maps);
        maps_version = lighting.maps_version;
      } else if (!lighting.maps && lighting.sh && lighting.sh_version != sh_version) {
        renderer.set_sh(*lighting.sh);
        sh_version = lighting.sh_version;
      }

      // Render where the marker is (held briefly through a lost frame), tone map, composite.
      renderer.begin_frame();
      const bool pose_fresh = last_pose && f->timestamp - last_pose_time <= 0.2;
      const bool draw = pose_fresh && world_from_scene &&
                        renderer.lighting_source() != render::LightingSource::None;
      if (draw) {
        renderer.set_camera(camera, track::view_matrix(*last_pose));
        renderer.set_world_from_scene(*world_from_scene);
        render::ShadowSettings shadow;  // the dominant light is in the world frame
        shadow.enabled = shadow_mode == "on";
        shadow.light_direction = lighting.dominant_direction;
        shadow.light_colour = lighting.dominant_colour;
        renderer.set_shadow(shadow);
        renderer.draw(gpu_mesh, material, model_matrix);
        ++(renderer.lighting_source() == render::LightingSource::Maps ? lit_by_maps : lit_by_sh);
      }
      tone.exposure = f->exposure > 0 ? f->exposure : 1.0 / 30;
      tone.gain = f->gain;
      renderer.composite(f->bgr, tone, composited);
      if (window) {
        renderer.present();
        gl.swap_buffers();
      }
      const render::FrameTimings& rt = renderer.timings();
      render_ms.push_back(rt.render_ms);
      tonemap_ms.push_back(rt.tonemap_ms + rt.readback_ms);
      // The client's own work per frame: tracking, rendering, tone mapping and compositing
      // (decoding a recording's JPEG and the network are reported apart).
      frame_ms.push_back(track_ms.back() + render_ms.back() + tonemap_ms.back());

      // Pose error against the simulator's truth, for frames where the marker is visible.
      if (truth && truth->marker && tr.tracked && f->index < truth->poses.size() &&
          f->index < truth->marker_visible.size() && truth->marker_visible[f->index]) {
        const track::Pose expected =
            track::compose(track::inverse(truth->marker->pose), truth->poses[f->index]);
        err_cm.push_back(100.0 * glm::length(tr.smoothed.position - expected.position));
        err_deg.push_back(track::angle_deg(tr.smoothed.orientation, expected.orientation));
      }

      if (!out.empty()) {
        char name[32];
        std::snprintf(name, sizeof name, "%06zu.png", written++);
        cv::imwrite((fs::path(out) / "frames" / name).string(), composited);
        if (draw && sheet.size() < 64) sheet.push_back(composited.clone());
      }
      std::printf("frame %zu: %s, %s, track %.1f ms, render %.1f ms, tonemap %.1f ms\n", f->index,
                  tr.tracked ? "tracked" : tr.status.c_str(),
                  !draw                                                        ? "not drawn"
                  : renderer.lighting_source() == render::LightingSource::Maps ? "maps"
                                                                               : "SH",
                  track_ms.back(), render_ms.back(), tonemap_ms.back());
    }

    const client_app::LinkStats ls = link.stats();
    if (!out.empty()) {
      // Eight drawn frames spread over the run, and an MP4 when ffmpeg is installed.
      std::vector<cv::Mat> picked;
      for (std::size_t i = 0; i < std::min<std::size_t>(8, sheet.size()); ++i)
        picked.push_back(sheet[i * sheet.size() / std::min<std::size_t>(8, sheet.size())]);
      write_contact_sheet(picked, fs::path(out) / "contact_sheet.png");
      if (std::system("command -v ffmpeg > /dev/null 2>&1") == 0) {
        const std::string cmd = "ffmpeg -loglevel error -y -framerate 30 -i '" +
                                (fs::path(out) / "frames" / "%06d.png").string() +
                                "' -pix_fmt yuv420p '" +
                                (fs::path(out) / "composited.mp4").string() + "'";
        if (std::system(cmd.c_str()) != 0) spdlog::warn("ffmpeg could not write the MP4");
      }
    }
    json j;
    j["frames"] = frames;
    j["tracked"] = tracked;
    j["median_frame_ms"] = median(frame_ms);
    j["stages_ms"] = {{"decode", median(decode_ms)},
                      {"tracking", median(track_ms)},
                      {"render", median(render_ms)},
                      {"tonemap", median(tonemap_ms)}};
    if (!err_cm.empty())
      j["pose_error"] = {{"median_cm", median(err_cm)},
                         {"median_deg", median(err_deg)},
                         {"p95_cm", percentile(err_cm, 0.95)},
                         {"p95_deg", percentile(err_deg, 0.95)},
                         {"max_cm", percentile(err_cm, 1.0)},
                         {"max_deg", percentile(err_deg, 1.0)},
                         {"frames", err_cm.size()}};
    j["lit_by_maps"] = lit_by_maps;
    j["lit_by_sh"] = lit_by_sh;
    j["session"] = {{"id", ls.session_id},           {"connects", ls.connects},
                    {"frames_sent", ls.frames_sent}, {"frames_not_sent", ls.frames_not_sent},
                    {"updates", ls.updates},         {"map_sets", ls.map_sets},
                    {"refused", ls.refused},         {"last_error", ls.last_error}};
    j["renderer"] = gl.renderer();
    j["size"] = {camera.width, camera.height};
    const std::string text = j.dump(2) + "\n";
    if (!json_path.empty()) write_file_atomically(json_path, text);
    if (!out.empty()) write_file_atomically(fs::path(out) / "client.json", text);
    std::printf(
        "%zu frames, %zu tracked, median %.1f ms per frame (tracking %.1f, render %.1f, "
        "tone map %.1f)%s%s\n",
        frames, tracked, median(frame_ms), median(track_ms), median(render_ms), median(tonemap_ms),
        out.empty() ? "" : "; frames in ", out.c_str());
    return frames > 0 ? 0 : 1;
  } catch (const InputError& e) {
    std::fprintf(stderr, "arlight-client: bad input: %s\n", e.what());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "arlight-client: error: %s\n", e.what());
    return 1;
  }
}
