// The client's per-frame pipeline, the same for every client (arlight-client, the benchmark,
// and the browser page next): a source frame -> the device's orientation (IMU, or marker +
// visual gyroscope for a webcam) -> the frame to arlightd -> the newest lighting (live SH until
// a map set arrives) -> render the virtual object on the marker -> tone map like the camera
// (thesis ch. 5, tutorial §4.1) -> composite -> a report of what happened and how long it took.
#pragma once

#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "arlight/app/lighting_link.hpp"
#include "arlight/app/placement.hpp"
#include "arlight/common/camera.hpp"
#include "arlight/common/frame.hpp"
#include "arlight/common/pose.hpp"
#include "arlight/common/response.hpp"
#include "arlight/render/opencv.hpp"
#include "arlight/render/render.hpp"
#include "arlight/source/source.hpp"
#include "arlight/track/track.hpp"

namespace arlight::client_app {

// Where the pipeline sends frames and gets its lighting: arlightd through a LightingLink, or a
// fixed lighting (benchmarks and tests that leave the network out).
class LightingChannel {
 public:
  virtual ~LightingChannel() = default;
  // Whether a camera frame of width x height taken at `timestamp` should go, how reduced and at
  // which JPEG quality (the daemon's frame advice, PROTOCOL.md); by default every frame, at its
  // size and kMaxQuality.
  virtual client::FramePacer::Decision frame_due(double /*timestamp*/, int /*width*/,
                                                 int /*height*/) {
    return {};
  }
  // `jpeg` was encoded at `quality` (what the next frames' quality is chosen by).
  virtual void send_frame(std::uint64_t sequence, const FrameInfo& info, int width, int height,
                          std::span<const std::uint8_t> jpeg, int quality) = 0;
  virtual Lighting lighting() const = 0;
};

class LinkChannel final : public LightingChannel {
 public:
  explicit LinkChannel(LightingLink& link) : link_(link) {}
  client::FramePacer::Decision frame_due(double timestamp, int width, int height) override {
    return link_.frame_due(timestamp, width, height);
  }
  void send_frame(std::uint64_t sequence, const FrameInfo& info, int width, int height,
                  std::span<const std::uint8_t> jpeg, int quality) override {
    link_.send_frame(sequence, info, width, height, jpeg, quality);
  }
  Lighting lighting() const override { return link_.lighting(); }

 private:
  LightingLink& link_;
};

// The same lighting for every frame; frames go nowhere.
class FixedLighting final : public LightingChannel {
 public:
  explicit FixedLighting(Lighting lighting) : lighting_(std::move(lighting)) {}
  void send_frame(std::uint64_t, const FrameInfo&, int, int, std::span<const std::uint8_t>,
                  int) override {}
  Lighting lighting() const override { return lighting_; }

 private:
  Lighting lighting_;
};

struct PipelineOptions {
  CameraIntrinsics camera;
  track::MarkerSpec marker{"DICT_4X4_50", 0, 0.2};
  double object_height = 0;  // metres; 0: 1.5 x the marker
  render::Material material;
  // The model's own materials (a glTF's, --material model), drawn on the parts that name one;
  // `material` on the rest. Empty: `material` everywhere.
  std::vector<render::Material> model_materials;
  bool shadow = true;  // shadows on the real floor (the marker's plane)
  // Soft shadows from the map set's light clusters (render::ShadowSettings::lights): at most
  // this many hard shadows, and as many as hold target_fps for the client's own work per frame
  // (render::LightCountControl, tutorial §6.4); target_fps 0 (or draw_at_true_pose, for
  // reproducible evaluations): always shadow_lights.
  int shadow_lights = 16;
  double target_fps = 30;
  render::ToneMode tone = render::ToneMode::CameraMatched;
  render::ColourCorrection colour = render::ColourCorrection::None;  // dissertation §5.6
  render::Shading shading = render::Shading::ImageBased;
  // What a glass material shows through it (render::Refraction; only transmissive materials).
  render::Refraction refraction = render::Refraction::Maps;
  CameraResponse response = CameraResponse::srgb();
  // The camera's true pose in the marker frame for a frame index, where known (a simulated
  // recording's ground truth) and the marker in view: pose errors are measured against it.
  std::function<std::optional<Pose>(std::size_t frame_index)> true_pose;
  // Draw at that true pose instead of the tracked one, with the marker's true rotation into the
  // world (evaluations of the lighting alone, arlight-eval): every frame with a true pose is
  // drawn, from the first; frames without one are not.
  bool draw_at_true_pose = false;
  glm::dquat true_world_from_marker{1, 0, 0, 0};
};

// What happened to one frame.
struct FrameReport {
  std::size_t index = 0;  // the source's frame number
  bool tracked = false;
  std::string track_status;  // "tracked" or why not
  bool sent = false;         // went to the lighting channel (a webcam before the marker: no)
  bool held_back = false;    // not sent: the daemon's frame advice asked for fewer frames
  int sent_width = 0, sent_height = 0;  // the size it went at (the advice may reduce it)
  bool exposure_requested = false;  // taken at arlightd's exposure advice
  bool drawn = false;
  render::LightingSource lit_by = render::LightingSource::None;
  bool lit_by_ggx = false;  // a metallic-roughness object shaded with the room's GGX chain
  double track_ms = 0, render_ms = 0, tonemap_ms = 0;
  double frame_ms = 0;  // the client's own work: tracking + render + tone map and composite
  int shadow_lights = 0;  // hard shadows blended into the soft one (0: none drawn)
  // Pose error against the truth, for frames where the marker is visible.
  std::optional<double> error_cm, error_deg;
  // How far the object's centre was drawn from where the truth projects it (pixels), for drawn
  // frames where the marker is visible (issue 36 §4).
  std::optional<double> object_error_px;
};

class FramePipeline {
 public:
  // Needs a current GL context (render::GlContext) for its whole life.
  FramePipeline(PipelineOptions options, const render::Mesh& mesh);

  // One frame through the whole pipeline; `composited` receives the frame with the object in.
  FrameReport process(const source::SourceFrame& frame, LightingChannel& lighting,
                      cv::Mat& composited);

  render::Renderer& renderer() { return renderer_; }

 private:
  PipelineOptions options_;
  render::Renderer renderer_;
  render::GpuMesh mesh_;
  glm::mat4 model_matrix_;
  track::MarkerTracker tracker_;
  track::WorldFromMarker world_from_marker_;
  track::OrientationEstimator webcam_orientation_;
  ShadowBudget shadow_budget_;
  std::uint64_t sh_version_ = 0, maps_version_ = 0, ggx_version_ = 0;
  MarkerPlacement placement_;  // the smoothed pose, held through a briefly lost marker
};

// Flag values every client takes, with errors naming the flag.
track::MarkerSpec parse_marker(const std::string& text);   // --marker ID,SIZE_M (DICT_4X4_50)
// --material kd,ks,shininess (Phong) or pbr:R,G,B,METALLIC,ROUGHNESS (glTF metallic-roughness);
// "model" (the glTF's own materials, PipelineOptions::model_materials) gives the Phong default
// for the parts without one.
render::Material parse_material(const std::string& text);
render::ToneMode parse_tone(const std::string& name);      // --tone camera|reinhard|linear
// --tone MODE[,CORRECTION]: the tone mode and the colour correction (none when not given;
// brightness, contrast or match: render::ColourCorrection).
std::pair<render::ToneMode, render::ColourCorrection> parse_tone_options(const std::string& text);
// --shading maps|hemisphere|hemisphere-occlusion (render::Shading)
render::Shading parse_shading(const std::string& name);
// --glass off|maps|live: std::nullopt (the --material), or what clear glass shows through it.
std::optional<render::Refraction> parse_glass(const std::string& name);
// --ior: clear glass (render::glass) of that index of refraction, in [1, 3].
render::Material glass_material(double ior, double shininess);
render::Mesh load_model(const std::string& name);          // --model a glTF file, or "sphere"
// The same with the glTF's materials (none for "sphere"), for --material model.
render::GltfModel load_model_with_materials(const std::string& name);

// --occlusion baked: the mesh with its occlusion of itself and of the floor baked
// (render::bake_occlusion), unless it came with one. Bakes are kept in `cache_dir` (one .glb per
// mesh, named by the xxHash of its geometry, and the bake's version and ray count), so a model
// is baked once per machine; a cached file that does not read back is baked again and replaced,
// and a cache that cannot be written only costs the next start a bake. state: "file" (it came
// baked), "cached" or "baked".
struct BakedModel {
  render::Mesh mesh;
  std::string state;
  double bake_ms = 0;  // the bake itself, or reading it from the cache
};
BakedModel bake_model(render::Mesh mesh, const std::filesystem::path& cache_dir);
// $XDG_CACHE_HOME/arlight/bake, or ~/.cache/arlight/bake; empty when neither is set.
std::filesystem::path default_bake_cache();

// Median, 95th percentile and maximum of a run's figures (what arlight-client reports).
struct RunStats {
  std::vector<double> frame_ms, track_ms, render_ms, tonemap_ms, decode_ms, error_cm, error_deg,
      object_error_px;
  std::vector<double> shadow_lights;  // of the frames whose shadow was drawn
  std::size_t frames = 0, tracked = 0, lit_by_maps = 0, lit_by_sh = 0, lit_by_ggx = 0;
  std::size_t exposure_requested = 0;  // frames taken at arlightd's exposure advice
  void add(const FrameReport& r, double decode_ms);
};
double median(std::vector<double> v);
double percentile(std::vector<double> v, double p);  // p in [0, 1]

}  // namespace arlight::client_app
