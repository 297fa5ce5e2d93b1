// CaptureSession's inside (capture.hpp), shared by its parts: capture_session.cpp (the public
// API and the map's state), capture_frame.cpp (one frame's path: decode, linearise, align,
// sample, merge, the live SH, clipping, the glance) and capture_devices.cpp (other devices'
// frames: registration and sensitivity, issue 49). Private to arlight_capture.
#pragma once

#include <algorithm>
#include <chrono>
#include <cmath>
#include <deque>
#include <future>
#include <glm/geometric.hpp>
#include <glm/gtc/quaternion.hpp>
#include <numbers>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <optional>
#include <stdexcept>

#include "align.hpp"
#include "arlight/capture/capture.hpp"
#include "arlight/common/pose.hpp"
#include "arlight/common/resample.hpp"
#include "drift_model.hpp"
#include "glance.hpp"
#include "jpeg_decode.hpp"
#include "linearize.hpp"
#include "map_view.hpp"
#include "registration.hpp"
#include "tile_index.hpp"

namespace arlight::capture {

using Clock = std::chrono::steady_clock;
inline double ms_since(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

inline std::string size_text(int w, int h) { return std::to_string(w) + "x" + std::to_string(h); }

// Mean angular size (radians) of a valid texel of the layout.
inline double texel_angle(const TexelTable& table) {
  return std::sqrt(4.0 * std::numbers::pi / double(table.size()));
}

// Largest angle between the optical axis and a ray through the image's edge.
inline double half_field_of_view(const PinholeCamera& cam) {
  const CameraIntrinsics& k = cam.intrinsics();
  double widest = 0.0;
  const double xs[] = {-0.5, k.width * 0.5 - 0.5, k.width - 0.5};
  const double ys[] = {-0.5, k.height * 0.5 - 0.5, k.height - 0.5};
  for (double x : xs)
    for (double y : ys)
      widest = std::max(widest, std::acos(std::clamp(-cam.unproject({x, y}).z, -1.0, 1.0)));
  return widest;
}

inline bool has_distortion(const CameraIntrinsics& k) {
  return std::any_of(k.distortion.begin(), k.distortion.end(), [](double d) { return d != 0.0; });
}

// One alignment: what it was measured against, and the fit.
struct AlignmentMeasurement {
  glm::dquat predicted{1, 0, 0, 0}, sensor{1, 0, 0, 0};
  double timestamp = 0;
  cv::Mat frame, rendered, mask;
  RotationFit fit;
};

// A frame of a device that is not registered yet, kept to be merged once it is.
struct WaitingFrame {
  LinearFrame frame;
  glm::dquat sensor{1, 0, 0, 0};
  double exposure_gain = 0.0;   // it was linearised at
  double radiance_scale = 1.0;  // its device's then
};

// One camera frames come from (issue 49 §1): the session's own, device 0, or a contributor's,
// each with its optics, response, exposure and the heading drift of its own sensor.
struct Device {
  CameraIntrinsics camera;
  PinholeCamera pinhole;
  CameraResponse response;
  bool estimate_exposure = false;  // CaptureOptions::estimate_exposure, per device
  double field_radius = 0.0;       // half field of view plus a margin
  int factor = 1;                  // linearised frames are reduced by this
  int reduction = 1;               // frames may come this much smaller (frame_reduction())
  CameraIntrinsics reduced_camera;
  double cos_field = -1.0;  // texels with d . forward below this are outside the view
  PinholeCamera align_camera{CameraIntrinsics{}};
  std::optional<MapView> align_view;  // the map as the alignment camera sees it
  DriftModel drift;  // the sensor's heading drift: used orientation = drift.offset() * sensor
  int frames_since_align = 0;
  std::future<AlignmentMeasurement> pending_alignment;  // align_async: measured on another thread
  std::optional<Glancer> glancer;   // CaptureOptions::glance (a cube map's only)
  double last_exposure_gain = 0.0;  // estimate_exposure: the last frame's exposure x gain
  // Registration (issue 49 §1; device 0 is the map's own frame). A contributor's sensor
  // orientation is turned by `base` (its heading against the map, found by fit_heading()) before
  // anything else sees it; its radiance is multiplied by `radiance_scale` (its camera's
  // sensitivity against the map's units). Until registered its frames wait in `waiting`.
  bool registered = true;
  glm::dquat base{1, 0, 0, 0};
  double radiance_scale = 1.0;
  int scale_frames = 0;  // frames after the registering one that measured radiance_scale
  std::optional<double> last_heading;  // the previous frame's fit, when it fitted
  int agreeing = 0;                    // frames in a row whose fits agree
  std::deque<WaitingFrame> waiting;

  Device(const CameraIntrinsics& k, CameraResponse r, bool estimate, const CaptureOptions& options,
         const TexelTable& table)
      : camera(k),
        pinhole(k),
        response(std::move(r)),
        estimate_exposure(estimate),
        drift(options.align_smoothing, options.align_max_drift_deg_per_s) {
    if (k.width < 1 || k.height < 1 || !(k.fx > 0) || !(k.fy > 0) || !std::isfinite(k.cx) ||
        !std::isfinite(k.cy))
      throw std::invalid_argument("capture: camera intrinsics are not usable (size " +
                                  size_text(k.width, k.height) + ", fx " + std::to_string(k.fx) +
                                  ", fy " + std::to_string(k.fy) + ")");
    // Reduce frames until a pixel spans about one texel (finer only aliases), and align at
    // twice that resolution, where features are still sharp but cheap to find.
    const double pixel_angle = 1.0 / std::max(k.fx, k.fy);
    factor = std::max(1, int(std::floor(texel_angle(table) / pixel_angle)));
    reduced_camera = reduced_intrinsics(k, factor);
    field_radius = half_field_of_view(pinhole) + 0.02;
    cos_field = std::cos(std::min(std::numbers::pi, field_radius));
    int align_factor = std::max(1, factor / 2);
    while ((k.width + align_factor - 1) / align_factor > options.align_max_width) ++align_factor;
    align_camera = PinholeCamera(reduced_intrinsics(k, align_factor));
    // The largest power-of-two reduction (up to 8, libjpeg's) that divides the image, that the
    // alignment still resolves, and that leaves linearize() at least 2x2 pixels a block to
    // average in linear radiance: an average of codes is biased where a lamp's edge mixes
    // clipped and dark pixels (lab's irradiance error 0.8 % -> 2.6 % with none left, measured
    // with bench/capture_merge.sh on 320x240 frames).
    for (int r = 2; r <= 8 && factor % r == 0 && 2 * r <= factor && r <= align_factor &&
                    k.width % r == 0 && k.height % r == 0;
         r *= 2)
      reduction = r;
    align_view.emplace(align_camera, response);
    if (options.glance && options.layout.projection() == Projection::Cube)
      glancer.emplace(k, reduction, factor, options.layout, table.solid_angle);
  }
};

struct CaptureSession::Impl {
  CaptureOptions options;
  std::shared_ptr<const TexelTable> table;
  std::shared_ptr<const TileIndex> tile_index;   // shared by every session of this layout
  std::vector<std::unique_ptr<Device>> devices;  // [0] the session's own camera

  std::vector<float> weighted_radiance;        // sum(w * L) per layout texel, RGB
  std::vector<float> weight;                   // sum(w) per layout texel
  std::vector<glm::dvec3> sh_dirs, sh_values;  // a frame's changed texels (kept: no reallocation)
  ShCoeffs sh;
  double covered_solid_angle = 0.0;
  // The fill of the unseen part, refitted lazily when the map has changed since.
  mutable UnseenEstimator unseen;
  mutable ShCoeffs unseen_part;  // the model's SH over what is unseen
  mutable ShCoeffs filled_sh;    // sh + unseen_part
  mutable bool unseen_stale = true;
  // Since the last fit: frames that changed the map, and the solid angle they saw first.
  mutable int frames_since_fit = 0;
  mutable double seen_since_fit = 0.0;
  mutable std::size_t fits = 0;
  mutable LightUncertainty light_uncertainty;  // of the fit numbered uncertainty_fit
  mutable std::size_t uncertainty_fit = 0;
  mutable std::size_t uncertainty_clips = 0;  // and of clipped_frames
  std::size_t clipped_frames = 0;  // frames with clipped blocks: a clip floor may have changed
  std::vector<std::uint32_t> newly_seen;  // a frame's first-measured texels (kept)
  std::vector<float> ratio_scratch;       // exposure_ratio()'s samples
  // Per texel, the largest radiance its clipped pixels have proved it to have (a clipped pixel
  // of a frame taken at exposure x gain E is at least linear(250) / E): what the exposure
  // advice needs to know how much darker the next frame must be. Not checkpointed: a resumed
  // session relearns it from its next clipped frames.
  std::vector<float> clip_floor;
  std::size_t added = 0, used = 0;

  Impl(const CameraIntrinsics& k, CameraResponse r, CaptureOptions o)
      : options(std::move(o)), unseen(options.layout, options.fill, options.fill_options) {
    if (options.align_every < 1) throw std::invalid_argument("capture: align_every must be >= 1");
    if (options.fill_refit_frames < 1 || !(options.fill_refit_coverage >= 0.0))
      throw std::invalid_argument(
          "capture: fill_refit_frames must be >= 1 and fill_refit_coverage >= 0");
    light_uncertainty = LightUncertainty({}, options.uncertainty);  // checks its options
    if (options.sh_order < 3 || options.sh_order > 64)
      throw std::invalid_argument("capture: SH order must be in [3, 64], got " +
                                  std::to_string(options.sh_order));
    table = texel_table(options.layout);
    tile_index = tile_index_for(options.layout);
    devices.push_back(
        std::make_unique<Device>(k, std::move(r), options.estimate_exposure, options, *table));
    weighted_radiance.assign(options.layout.texel_count() * 3, 0.0f);
    weight.assign(options.layout.texel_count(), 0.0f);
    clip_floor.assign(options.layout.texel_count(), 0.0f);
    sh = ShCoeffs(options.sh_order);
  }

  Device& device(int d) const {
    if (d < 0 || std::size_t(d) >= devices.size())
      throw std::invalid_argument("capture: no device " + std::to_string(d) + " (the session has " +
                                  std::to_string(devices.size()) + ")");
    return *devices[std::size_t(d)];
  }

  void refit_unseen() const {
    if (!unseen_stale) return;
    unseen.fit({weighted_radiance, weight});
    ++fits;
    unseen_part = unseen.unseen_sh(sh.order);
    update_filled_sh();
    unseen_stale = false;
    frames_since_fit = 0, seen_since_fit = 0.0;
  }

  // After a frame changed the map (the measured SH has followed it): the model's part loses
  // what the frame saw first, or the model is due for a refit (options.fill_refit_*).
  void follow_unseen(double newly_seen_omega) {
    if (options.fill == Fill::None || unseen_stale) return;
    if (!(unseen.measured_fraction() > 0.0)) {  // the last fit had nothing to go on
      unseen_stale = true;
      return;
    }
    // All seen at the last fit (to within a fraction of a texel): the model has no part.
    if (!(unseen.estimated_fraction() > 1e-6)) {
      update_filled_sh();
      return;
    }
    ++frames_since_fit, seen_since_fit += newly_seen_omega;
    if (frames_since_fit >= options.fill_refit_frames ||
        seen_since_fit >= options.fill_refit_coverage * 4.0 * std::numbers::pi) {
      unseen_stale = true;
      return;
    }
    unseen.remove_from_unseen_sh(unseen_part, newly_seen);
    update_filled_sh();
  }

  void update_filled_sh() const {
    filled_sh = sh;
    for (std::size_t k = 0; k < unseen_part.c.size(); ++k) filled_sh.c[k] += unseen_part.c[k];
  }

  glm::vec3 texel_radiance(std::size_t texel) const {
    const float w = weight[texel];
    if (!(w > 0.0f)) return glm::vec3(0.0f);
    const float* p = &weighted_radiance[3 * texel];
    return glm::vec3(p[0], p[1], p[2]) / w;
  }

  // Kán's alignment: a corrected orientation for the frame, or the sensor's with the predicted
  // offset when the features do not allow one.
  glm::dquat align(Device& d, const cv::Mat& bgr8, const FrameInfo& info, const glm::dquat& sensor,
                   FrameResult& result);

  // Turns a measured correction into the drift offset (or says why not).
  void apply_alignment(Device& d, const AlignmentMeasurement& m, FrameResult& result);

  // Calls visit(k, sw, r, g, b) for every map texel (tile-index position k) in view of a frame
  // at `orientation`: the frame sampled bilinearly where the texel's direction meets the image
  // plane (thesis ch. 3), sw the sampled weight (> 1e-6), r, g, b the sampled w * L.
  template <class Visit>
  void for_each_sample(const Device& d, const LinearFrame& frame, const glm::dquat& orientation,
                       Visit&& visit) const {
    const glm::mat3 to_camera = glm::transpose(glm::mat3(glm::mat3_cast(orientation)));
    const glm::vec3 forward = glm::vec3(glm::mat3_cast(orientation) * glm::dvec3(0, 0, -1));
    const float cos_limit = float(d.cos_field);
    const bool distorted = has_distortion(d.camera);
    const CameraIntrinsics& rk = d.reduced_camera;
    const float fx = float(rk.fx), fy = float(rk.fy), cx = float(rk.cx), cy = float(rk.cy);
    const float max_x = float(frame.width - 1), max_y = float(frame.height - 1);
    const TileIndex& ti = *tile_index;
    const std::vector<float>&dir_x = ti.dir_x, &dir_y = ti.dir_y, &dir_z = ti.dir_z;
    for (const TileIndex::Tile& tile : ti.tiles) {
      const float off_axis = std::acos(std::clamp(glm::dot(tile.centre, forward), -1.0f, 1.0f));
      if (off_axis - tile.radius > float(d.field_radius)) continue;
      for (std::size_t k = tile.begin; k < tile.end; ++k) {
        if (dir_x[k] * forward.x + dir_y[k] * forward.y + dir_z[k] * forward.z < cos_limit)
          continue;
        const glm::vec3 c = to_camera * glm::vec3(dir_x[k], dir_y[k], dir_z[k]);
        if (!(c.z < 0.0f)) continue;
        float px, py;
        if (!distorted) {
          px = fx * (c.x / -c.z) + cx;
          py = fy * (-c.y / -c.z) + cy;
        } else {
          const auto p = d.pinhole.project(glm::dvec3(c));
          if (!p) continue;
          px = float((p->x - 0.5 * (d.factor - 1)) / d.factor);
          py = float((p->y - 0.5 * (d.factor - 1)) / d.factor);
        }
        if (!(px >= 0.0f && py >= 0.0f && px <= max_x && py <= max_y)) continue;
        const int x0 = std::min(int(px), frame.width - 2 < 0 ? 0 : frame.width - 2);
        const int y0 = std::min(int(py), frame.height - 2 < 0 ? 0 : frame.height - 2);
        const int x1 = std::min(x0 + 1, frame.width - 1), y1 = std::min(y0 + 1, frame.height - 1);
        const float ax = px - float(x0), ay = py - float(y0);
        const float f[4] = {(1 - ax) * (1 - ay), ax * (1 - ay), (1 - ax) * ay, ax * ay};
        const std::size_t s[4] = {
            std::size_t(y0) * frame.width + x0, std::size_t(y0) * frame.width + x1,
            std::size_t(y1) * frame.width + x0, std::size_t(y1) * frame.width + x1};
        float sw = 0.0f, r = 0.0f, g = 0.0f, b = 0.0f;
        for (int q = 0; q < 4; ++q) {
          sw += f[q] * frame.weight[s[q]];
          const float* w = &frame.weighted_radiance[3 * s[q]];
          r += f[q] * w[0], g += f[q] * w[1], b += f[q] * w[2];
        }
        if (sw > 1e-6f) visit(k, sw, r, g, b);
      }
    }
  }

  // The frame's exposure x gain relative to the one it was linearised with, from where it
  // overlaps what the map holds already (issue 16 §4: frames whose exposure is unknown): the
  // median over the well-exposed samples (mean weight >= 0.5, so not near clipping or black)
  // of texels measured with confidence (sum of weights >= 1) of frame luminance / map
  // luminance. The gain compensation of panorama stitchers, with a median instead of least
  // squares so that what moved or was misaligned does not bias it. std::nullopt when fewer
  // than `kMinSamples` samples overlap.
  std::optional<double> exposure_ratio(const Device& d, const LinearFrame& frame,
                                       const glm::dquat& orientation, int& samples);

  // A sample or a texel of at least this weight is measured well: about half a well-exposed
  // pixel's (code_weight 1, away from the border), or more (CaptureOptions::changed_ratio).
  static constexpr float kWellMeasured = 0.5f;
  // A frame's sample of one texel (for_each_sample()'s): tile-index position, weight sw and
  // weighted radiance.
  struct Sample {
    std::uint32_t k;
    float sw, r, g, b;
  };
  std::vector<Sample> samples_scratch;  // a frame's samples (kept: no reallocation)

  // Merges a sample into its texel's accumulators: the weighted mean, with the weight held at
  // confident_weight and a changed room replacing what was there (CaptureOptions).
  void merge(const Sample& s, std::size_t texel);

  // Projects the linearised frame into the map (thesis ch. 3) and updates the live SH; a frame
  // that would change nothing (CaptureOptions::unchanged_share) is only sampled.
  void project(const Device& d, const LinearFrame& frame, const glm::dquat& orientation,
               FrameResult& result);

  // The frame's clipped pixels against what the map has measured (issue 16 §4, exposure
  // advice). A clipped block proves its texel's radiance is at least linear(250) / exposure:
  // the texel's clip floor keeps the largest such proof. Where the map holds less than that
  // (clipped pixels weigh 1e-3, so a texel only ever seen clipped holds the unclipped pixels
  // around the light, or its lowest bound), the light is not measured yet. (Counting texels
  // by weight instead took the wall around a lamp for the lamp: 12 % error on lab, not 2.6.)
  // Reports the unmeasured share of the frame and the brightest floor among it. Runs only
  // over the frame's clipped blocks (none in most frames).
  // A texel holding this share of its clip floor has its light measured.
  static constexpr float kMeasuredShare = 0.9f;
  void check_clipped(const Device& d, const LinearFrame& frame, const glm::dquat& orientation,
                     double exposure_gain, FrameResult& result);

  // The exposure x gain a frame is taken at in the map's units: an unknown exposure's last
  // estimate (auto-exposure moves slowly), or the reported one over the device's sensitivity
  // against the map (a contributor's radiance_scale; 1 for the session's own camera).
  double map_exposure_gain(const Device& d, const FrameInfo& info) const {
    if (d.estimate_exposure && d.last_exposure_gain > 0.0) return d.last_exposure_gain;
    return info.exposure * info.gain / d.radiance_scale;
  }

  // CaptureOptions::glance: `bytes` decoded at 1/8 of its size and compared with the map's
  // blocks at the predicted orientation. The frame's result when it is unchanged; nothing when
  // it has to be processed (its skip reasons are then the full path's).
  std::optional<FrameResult> glance(Device& d, std::span<const std::uint8_t> bytes,
                                    const FrameInfo& info);

  // Brings a frame to the map's exposure where it overlaps what the map holds (issue 16 §4's
  // median ratio) when its exposure is unknown: returns the exposure x gain it then has. A
  // contributor that reports its exposure is not corrected frame by frame: its sensitivity,
  // radiance_scale, is measured by the frame that registers it (`registering`: that frame is
  // corrected too) and the mean (in log) of the ratios of its next kScaleFrames frames, then
  // kept. Those frames overlap the map the others built; later ones overlap mostly its own
  // frames, whose ratio only walks (0.1 of each frame's ratio followed over a sweep: forest's
  // scale 6 % off by the end, 4.0 % irradiance error against one phone's 2.1 %), and a darker
  // frame the exposure advice asked for overlaps the map only at its lamps, which the map may
  // hold only as clipping's lower bound (a per-frame correction there dimmed hall's lamps: 8.3 %
  // against 3.7 %).
  static constexpr int kScaleFrames = 8;
  double match_exposure(Device& d, LinearFrame& frame, const glm::dquat& orientation,
                        double exposure_gain, bool registering, FrameResult& result);

  // Issue 49 §1: a frame of a device not registered yet. It is laid on the map at every heading
  // (fit_heading()); the device registers when kAgreeingFrames frames in a row fit within
  // kAgreeDeg of each other, and then the frames that waited are merged with it. Until then
  // the frame waits (the newest kMaxWaiting do) and is not merged: a heading that is not sure
  // never puts another room, or the wrong wall, into the map.
  static constexpr int kAgreeingFrames = 2;
  static constexpr double kAgreeDeg = 2.0;
  static constexpr std::size_t kMaxWaiting = 8;
  FrameResult register_or_wait(Device& d, LinearFrame frame, const glm::dquat& sensor,
                               double exposure_gain, FrameResult result);

  // `scale` > 1: the image was decoded already reduced by that factor (JPEG DCT scaling).
  FrameResult add(Device& d, const cv::Mat& bgr8, const FrameInfo& info, FrameResult result,
                  int scale = 1);
};

}  // namespace arlight::capture
