#include "arlight/app/client_app.hpp"

#include <spdlog/spdlog.h>
#include <xxhash.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "arlight/common/atomic_file.hpp"
#include "arlight/common/camera.hpp"
#include "arlight/common/error.hpp"
#include "arlight/common/number_list.hpp"

namespace arlight::client_app {

namespace {

using Clock = std::chrono::steady_clock;

double ms_since(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

// How long the last pose stands in for a marker lost for a moment (motion blur, a hand).
constexpr double kPoseHoldSeconds = 0.2;
// Exposure assumed for a source that cannot report one (a webcam on auto exposure).
constexpr double kUnknownExposure = 1.0 / 30;

PipelineOptions with_defaults(PipelineOptions o) {
  if (o.object_height <= 0) o.object_height = 1.5 * o.marker.size_m;
  if (o.shadow_lights < 1 || o.shadow_lights > render::kMaxShadowLights)
    throw InputError("--shadow-lights: between 1 and " + std::to_string(render::kMaxShadowLights));
  if (!(o.target_fps >= 0) || o.target_fps > 1000)
    throw InputError("--target-fps: frames a second in [0, 1000] (0: no frame-rate control)");
  return o;
}

}  // namespace

FramePipeline::FramePipeline(PipelineOptions options, const render::Mesh& mesh)
    : options_(with_defaults(std::move(options))),
      renderer_(options_.camera.width, options_.camera.height),
      mesh_(mesh),
      model_matrix_(render::standing_on_marker(mesh.bounds, float(options_.object_height))),
      tracker_(options_.camera, options_.marker),
      webcam_orientation_(options_.camera),
      // Evaluations at the true pose are reproducible: their shadow lights do not follow the
      // clock.
      shadow_budget_(options_.shadow_lights,
                     options_.draw_at_true_pose ? 0.0 : options_.target_fps),
      placement_({.hold_s = kPoseHoldSeconds}) {
  renderer_.set_response(options_.response);
  renderer_.set_shading(options_.shading);
  renderer_.set_refraction(options_.refraction);
}

FrameReport FramePipeline::process(const source::SourceFrame& f, LightingChannel& channel,
                                   cv::Mat& composited) {
  FrameReport report;
  report.index = f.index;
  report.exposure_requested = f.exposure_requested;

  // Tracking, then the orientation that goes to arlightd and the lighting's rotation.
  const auto t1 = Clock::now();
  const track::TrackResult tr = tracker_.track(f.bgr, f.timestamp);
  std::optional<glm::dquat> world_from_camera = f.orientation;
  std::optional<glm::dquat> world_from_scene;
  if (world_from_camera) {  // a phone: IMU orientation; the marker's rotation estimated
    if (tr.tracked) world_from_marker_.add(f.timestamp, *world_from_camera, tr.raw.orientation);
    world_from_scene = world_from_marker_.world_from_marker();
  } else {  // a webcam: the world is defined by the marker, the visual gyro in between
    const track::OrientationEstimate est = webcam_orientation_.update(f.bgr, f.timestamp, &tr);
    world_from_camera = est.orientation;
    world_from_scene = track::webcam_world_from_marker();
  }
  if (options_.draw_at_true_pose) {
    if (const auto truth = options_.true_pose ? options_.true_pose(f.index) : std::nullopt)
      placement_.tracked(f.timestamp, *truth);
    else
      placement_.forget();
    world_from_scene = options_.true_world_from_marker;
  } else if (tr.tracked) {
    placement_.tracked(f.timestamp, tr.smoothed);
  }
  report.tracked = tr.tracked;
  report.track_status = tr.tracked ? "tracked" : tr.status;
  report.track_ms = ms_since(t1);

  // To arlightd: the frame with its orientation (none yet: a webcam before the marker).
  const double exposure = f.exposure > 0 ? f.exposure : kUnknownExposure;
  // At the size, rate and JPEG quality the daemon's frame advice asks for (PROTOCOL.md): reduced
  // in one step by area averaging, then encoded (a source's own JPEG goes as it is when neither
  // is asked for: it is taken to be kMaxQuality's).
  const client::FramePacer::Decision due =
      world_from_camera ? channel.frame_due(f.timestamp, f.bgr.cols, f.bgr.rows)
                        : client::FramePacer::Decision{};
  report.held_back = world_from_camera && !due.send;
  if (world_from_camera && due.send) {
    cv::Mat image = f.bgr;
    if (due.reduction > 1)
      cv::resize(f.bgr, image, cv::Size(f.bgr.cols / due.reduction, f.bgr.rows / due.reduction),
                 0, 0, cv::INTER_AREA);
    std::vector<std::uint8_t> encoded;
    const bool reencode =
        f.jpeg.empty() || due.reduction > 1 || due.quality < client::FramePacer::kMaxQuality;
    if (reencode) cv::imencode(".jpg", image, encoded, {cv::IMWRITE_JPEG_QUALITY, due.quality});
    channel.send_frame(f.index + 1, {f.timestamp, exposure, f.gain, *world_from_camera}, image.cols,
                       image.rows, reencode ? encoded : f.jpeg, due.quality);
    report.sent = true;
    report.sent_width = image.cols, report.sent_height = image.rows;
  }

  // Lighting: the newest map set once there is one, the live SH before.
  const Lighting lighting = channel.lighting();
  if (lighting.maps && lighting.maps_version != maps_version_) {
    renderer_.set_maps(lighting.maps->shininess, lighting.maps->maps);
    maps_version_ = lighting.maps_version;
  } else if (!lighting.maps && lighting.sh && lighting.sh_version != sh_version_) {
    renderer_.set_sh(*lighting.sh);
    sh_version_ = lighting.sh_version;
  }
  // The room's GGX chain (metallic-roughness materials' specular), when the link asked for one.
  if (lighting.ggx && lighting.ggx_version != ggx_version_) {
    ggx_version_ = lighting.ggx_version;
    try {
      renderer_.set_ggx_chain(lighting.ggx->maps, lighting.ggx->roughness, lighting.ggx->lights);
    } catch (const std::invalid_argument& e) {
      spdlog::warn("GGX chain not used: {}", e.what());
    }
  }

  // Render where the marker is (held briefly through a lost frame), tone map, composite.
  renderer_.begin_frame();
  const std::optional<Pose> pose = placement_.camera_in_marker(f.timestamp);
  report.drawn =
      pose && world_from_scene && renderer_.lighting_source() != render::LightingSource::None;
  if (report.drawn) {
    renderer_.set_camera(options_.camera, track::view_matrix(*pose));
    renderer_.set_world_from_scene(*world_from_scene);
    renderer_.set_shadow(shadow_budget_.settings(options_.shadow, lighting));
    renderer_.draw(mesh_, options_.model_materials, options_.material, model_matrix_);
    report.lit_by = renderer_.lighting_source();
    report.lit_by_ggx = render::needs_ggx_chain(options_.model_materials, options_.material) &&
                        renderer_.has_ggx_chain();
  }
  render::ToneMapping tone;
  tone.mode = options_.tone;
  tone.colour = options_.colour;
  tone.exposure = exposure;
  tone.gain = f.gain;
  render::composite(renderer_, f.bgr, tone, composited);
  const render::FrameTimings& rt = renderer_.timings();
  report.render_ms = rt.render_ms;
  report.tonemap_ms = rt.tonemap_ms + rt.readback_ms;
  // The client's own work per frame (decoding a recording's JPEG and the network apart).
  report.frame_ms = report.track_ms + report.render_ms + report.tonemap_ms;
  report.shadow_lights = rt.shadow_lights;
  // Tutorial §6.4: the next frame's shadow lights from this one's time (frames with a shadow
  // pass; it may have drawn fewer hard shadows than asked, or none, when clusters are broad).
  shadow_budget_.frame_took(report.frame_ms, report.drawn && options_.shadow);

  // Pose error against the truth, where it is known, and where that put the object.
  const auto expected = options_.true_pose ? options_.true_pose(f.index) : std::nullopt;
  if (expected && tr.tracked) {
    report.error_cm = 100.0 * glm::length(tr.smoothed.position - expected->position);
    report.error_deg = angle_deg(tr.smoothed.orientation, expected->orientation);
  }
  if (expected && report.drawn) {
    const PinholeCamera camera(options_.camera);
    const glm::dvec3 centre(0.0, 0.0, 0.5 * options_.object_height);
    const auto pixel = [&](const Pose& p) {
      return camera.project(glm::conjugate(p.orientation) * (centre - p.position));
    };
    const auto drawn_at = pixel(*pose), true_at = pixel(*expected);
    if (drawn_at && true_at) report.object_error_px = glm::length(*drawn_at - *true_at);
  }
  return report;
}

track::MarkerSpec parse_marker(const std::string& text) {
  const std::vector<double> mk = parse_number_list(text, "--marker");
  if (mk.size() != 2 || !(mk[1] > 0) || mk[0] < 0 || mk[0] != std::floor(mk[0]))
    throw InputError("--marker: ID,SIZE_M with an integer ID and a size > 0");
  return {"DICT_4X4_50", int(mk[0]), mk[1]};
}

render::Material parse_material(const std::string& text) {
  if (text == "model") return {};
  if (text.rfind("pbr:", 0) == 0) {
    const std::vector<double> v = parse_number_list(text.substr(4), "--material pbr:");
    if (v.size() != 5 || std::any_of(v.begin(), v.end(), [](double x) { return !(x >= 0 && x <= 1); }))
      throw InputError("--material pbr:R,G,B,METALLIC,ROUGHNESS with every value in [0, 1]");
    render::Material m;
    m.pbr = render::MetallicRoughness{};
    m.pbr->base_colour = glm::vec4(float(v[0]), float(v[1]), float(v[2]), 1.0f);
    m.pbr->metallic = float(v[3]);
    m.pbr->roughness = float(v[4]);
    return m;
  }
  const std::vector<double> mat = parse_number_list(text, "--material");
  if (mat.size() != 3 || mat[0] < 0 || mat[1] < 0 || !(mat[2] >= 1))
    throw InputError("--material: kd,ks,s with kd, ks >= 0 and s >= 1");
  render::Material m;
  m.kd = glm::vec3(float(mat[0]));
  m.ks = glm::vec3(float(mat[1]));
  m.shininess = float(mat[2]);
  return m;
}

render::ToneMode parse_tone(const std::string& name) {
  if (name == "camera") return render::ToneMode::CameraMatched;
  if (name == "reinhard") return render::ToneMode::Reinhard;
  if (name == "linear") return render::ToneMode::Linear;
  throw InputError("--tone: '" + name + "' is not camera, reinhard or linear");
}

std::pair<render::ToneMode, render::ColourCorrection> parse_tone_options(const std::string& text) {
  const std::size_t comma = text.find(',');
  const render::ToneMode mode = parse_tone(text.substr(0, comma));
  if (comma == std::string::npos) return {mode, render::ColourCorrection::None};
  const std::string name = text.substr(comma + 1);
  if (const auto c = render::colour_correction_named(name); c && name != "none") return {mode, *c};
  throw InputError("--tone: '" + name +
                   "' is not a colour correction (brightness, contrast or match)");
}

render::Shading parse_shading(const std::string& name) {
  if (const auto s = render::shading_named(name)) return *s;
  throw InputError("--shading: '" + name + "' is not maps, hemisphere or hemisphere-occlusion");
}

std::optional<render::Refraction> parse_glass(const std::string& name) {
  if (name == "off") return std::nullopt;
  if (const auto r = render::refraction_named(name)) return r;
  throw InputError("--glass: '" + name + "' is not off, maps or live");
}

render::Material glass_material(double ior, double shininess) {
  if (!(ior >= 1.0 && ior <= 3.0))
    throw InputError("--ior: the index of refraction must be in [1, 3] (glass 1.5, water 1.33)");
  return render::glass(float(ior), float(std::max(shininess, 1.0)));
}

render::Mesh load_model(const std::string& name) {
  render::Mesh mesh =
      name == "sphere" ? render::make_sphere(0.5f, 64, 128) : render::load_gltf(name);
  if (mesh.positions.empty()) throw InputError(name + ": no triangles");
  return mesh;
}

render::GltfModel load_model_with_materials(const std::string& name) {
  if (name == "sphere") return {load_model(name), {}, {}, {}};
  render::GltfModel model = render::load_gltf_model(name);
  for (const std::string& w : model.warnings) spdlog::warn("{}", w);
  return model;
}

BakedModel bake_model(render::Mesh mesh, const std::filesystem::path& cache_dir) {
  using Clock = std::chrono::steady_clock;
  const auto start = Clock::now();
  const auto ms = [&] {
    return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
  };
  const auto baked = [](const render::Mesh& m) {
    return m.occlusion.size() == m.vertex_count() &&
           m.transfer.size() == m.vertex_count() * render::kTransferCoefficients &&
           !m.ground.empty();
  };
  if (baked(mesh)) return {std::move(mesh), "file", 0.0};
  constexpr int kDirections = 1024;  // render::bake_occlusion's default
  mesh.occlusion.clear(), mesh.transfer.clear(), mesh.ground = {};
  std::filesystem::path cached;
  if (!cache_dir.empty()) {
    const std::vector<std::uint8_t> geometry = render::encode_glb(mesh);
    char name[64];
    // v2: with the SH-9 transfer (a v1 file, occlusion only, is not read).
    std::snprintf(name, sizeof name, "%016llx-v2-%d.glb",
                  static_cast<unsigned long long>(XXH3_64bits(geometry.data(), geometry.size())),
                  kDirections);
    cached = cache_dir / name;
    std::error_code ec;
    if (std::filesystem::exists(cached, ec)) {
      try {
        render::Mesh back = render::load_gltf(cached);
        if (back.vertex_count() == mesh.vertex_count() && baked(back)) {
          mesh.occlusion = std::move(back.occlusion), mesh.transfer = std::move(back.transfer);
          mesh.ground = std::move(back.ground);
          return {std::move(mesh), "cached", ms()};
        }
        spdlog::warn("{}: not this model's bake; baking again", cached.string());
      } catch (const InputError& e) {
        spdlog::warn("the bake cache's {}; baking again", e.what());
      }
    }
  }
  render::bake_occlusion(mesh, kDirections);
  const double bake_ms = ms();
  if (!cached.empty()) {
    try {
      std::filesystem::create_directories(cached.parent_path());
      const std::vector<std::uint8_t> glb = render::encode_glb(mesh);
      write_file_atomically(
          cached, std::string_view(reinterpret_cast<const char*>(glb.data()), glb.size()));
    } catch (const std::exception& e) {  // a read-only or full disk: the next start bakes again
      spdlog::warn("could not keep the bake in {}: {}", cached.string(), e.what());
    }
  }
  return {std::move(mesh), "baked", bake_ms};
}

std::filesystem::path default_bake_cache() {
  if (const char* xdg = std::getenv("XDG_CACHE_HOME"); xdg && *xdg)
    return std::filesystem::path(xdg) / "arlight" / "bake";
  if (const char* home = std::getenv("HOME"); home && *home)
    return std::filesystem::path(home) / ".cache" / "arlight" / "bake";
  return {};
}

void RunStats::add(const FrameReport& r, double decode) {
  ++frames;
  if (r.tracked) ++tracked;
  if (r.exposure_requested) ++exposure_requested;
  if (r.drawn) ++(r.lit_by == render::LightingSource::Maps ? lit_by_maps : lit_by_sh);
  if (r.drawn && r.lit_by_ggx) ++lit_by_ggx;
  frame_ms.push_back(r.frame_ms);
  track_ms.push_back(r.track_ms);
  render_ms.push_back(r.render_ms);
  tonemap_ms.push_back(r.tonemap_ms);
  decode_ms.push_back(decode);
  if (r.error_cm) error_cm.push_back(*r.error_cm), error_deg.push_back(*r.error_deg);
  if (r.object_error_px) object_error_px.push_back(*r.object_error_px);
  if (r.shadow_lights > 0) shadow_lights.push_back(r.shadow_lights);
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

}  // namespace arlight::client_app
