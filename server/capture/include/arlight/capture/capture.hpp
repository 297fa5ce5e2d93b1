// HDR environment-map capture from camera frames and device orientation (thesis ch. 3, after
// Kán [Kán15]): each frame is linearised with the inverse camera response and its exposure,
// aligned to what has been captured so far, and accumulated into an environment map as
// sum(w * L) and sum(w); low-order SH of the map are kept current from the texels each frame
// changes. One CaptureSession per capturing device; not thread-safe (the daemon serialises a
// session's frames), but sessions are independent.
#pragma once

#include <cstdint>
#include <glm/gtc/quaternion.hpp>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "arlight/capture/fill.hpp"
#include "arlight/capture/uncertainty.hpp"
#include "arlight/common/camera.hpp"
#include "arlight/common/frame.hpp"
#include "arlight/common/image.hpp"
#include "arlight/common/projection.hpp"
#include "arlight/common/response.hpp"
#include "arlight/common/sh.hpp"

namespace cv {
class Mat;
}

namespace arlight::capture {

// How a contributor's frames are registered with the session's map (issue 49 §1,
// fit_heading() in src/registration.hpp): its heading found by comparing its view with the map
// at every heading.
struct RegistrationOptions {
  // The coarse search: the map averaged onto a cube map of this face (2.8-degree texels at 32)
  // and the frame into blocks of about that size, every `coarse_step_deg` of heading.
  int coarse_face = 32;
  double coarse_step_deg = 1.0;
  // The fine search: every `fine_step_deg` within `fine_span_deg` of each of the best four
  // coarse peaks (each over `distinct_deg` from the better ones), on the map's own texels and
  // the frame's pixels.
  double fine_span_deg = 2.0;
  double fine_step_deg = 0.25;
  // A heading is taken when its fine correlation (less the elevation trend) is at least
  // `min_score` and exceeds every other peak's by `min_margin`, with at least `min_overlap` of the
  // frame's well-exposed blocks (and `min_blocks` of them) on measured map texels whose log
  // luminance varies by at least `min_contrast` (standard deviation: a blank wall fits anywhere).
  // Set on simulated views (tests/capture/test_registration.cpp, bench/RESULTS.md "Issue 49"):
  // the right room 0.96-1.00, another room's best 0.77.
  double min_score = 0.85;
  double min_margin = 0.1;
  double distinct_deg = 15.0;
  double min_overlap = 0.3;
  int min_blocks = 24;
  double min_contrast = 0.1;
};

struct CaptureOptions {
  EnvLayout layout = EnvLayout::for_size(Projection::AngleMap, 512);
  int sh_order = 8;   // live SH: bands 0..sh_order-1 (>= 3)
  bool align = true;  // feature-based drift correction (Kán's alignment)
  // Alignment: corners of the map rendered into the camera, followed into the frame by LK flow.
  int align_min_inliers = 12;       // fewer -> keep the sensor orientation (with the last offset)
  double align_max_step_deg = 3.0;  // a correction larger than this is treated as a mismatch
  // The correction follows the alignments with a constant drift rate (a gyro bias) fitted to
  // the last seconds of them: each alignment moves the offset by `align_smoothing` of what it
  // measured (so one bad match cannot jump).
  double align_smoothing = 0.6;
  double align_max_drift_deg_per_s = 3.0;
  int align_every = 1;        // try the alignment on every n-th frame; the others extrapolate
  int align_max_width = 320;  // the alignment works on the frame reduced to at most this wide
  // Measure the alignment (features, fit) on another thread and apply it at the next frame,
  // so a frame never waits for it (the daemon's live path). The result does not depend on
  // timing: the next frame waits for the measurement if it is not done yet.
  bool align_async = false;
  // JPEG frames that are reduced by 4 or more anyway are decoded at half size in the DCT
  // domain (libjpeg scaling): 2.5x faster decoding; codes are then averaged over 2x2 before
  // linearisation, a bias only at high-contrast edges.
  bool fast_decode = true;
  // What the map holds where nothing has been seen yet (arlight/capture/fill.hpp):
  // environment() and sh() are those of the filled map; measured_environment() and
  // measured_sh() those of what was seen, with black elsewhere.
  Fill fill = Fill::Estimate;
  FillOptions fill_options;
  // The bounds of the light around the fill and the next view (issue 48).
  UncertaintyOptions uncertainty;
  // The fill's model is refitted (a pass over the whole map, ~2 ms at 512) once
  // `fill_refit_frames` frames have changed the map or its coverage has grown by
  // `fill_refit_coverage` of the sphere since the last fit, whichever is first; in between,
  // sh() follows every frame exactly under the last model (the measured change added, the
  // model taken off what the frame saw first), and environment() fills with that model.
  // 1 (or a coverage of 0): refit after every frame.
  int fill_refit_frames = 8;
  double fill_refit_coverage = 0.02;
  // The frames' exposure x gain is unknown (most browsers; issue 16 §4): each frame's is
  // estimated relative to the map from where it overlaps what was captured already (a median
  // ratio over well-exposed samples); the first frame's reported value sets the map's scale,
  // and a frame that overlaps too little keeps the last estimate.
  bool estimate_exposure = false;
  // A room that changes, and frames that add nothing (issue 37 §1). A texel's weight stops
  // growing at `confident_weight` (about as many well-exposed frames): later frames move it by
  // their share of that, so a change in the room is followed in a few dozen frames instead of
  // being averaged away by all the earlier ones. A well-exposed sample (weight >= 0.5) that
  // differs from a texel measured with weight >= 0.5 by more than `changed_ratio` of the
  // brighter luminance replaces it: a light switched on (or off) shows at once; clipped and dark
  // samples never replace. A frame that sees nothing new and agrees with the map where both are
  // measured well (samples and texels of weight >= 0.5) is not merged (FrameResult::unchanged):
  // it costs its sampling, not the map's and the SH's update. It agrees when, in luminance x
  // solid angle over those texels, sum |frame - map| < `unchanged_share` x sum map (noise and
  // edges; a lamp switched on is far more) and |sum (frame - map)| < `unchanged_bias` x sum map
  // (noise cancels there, so a room dimming by more than that is followed). Measured on
  // simulated sweeps (bench/capture_merge.sh): a confident weight of 4, or replacing at a
  // quarter's difference, cost up to 0.2 points of irradiance error and 0.1° of alignment (the
  // map the alignment renders follows each misaligned frame); 16 and two thirds cost nothing.
  // Infinity, infinity, 0, 0: every frame merged into a plain weighted mean (before issue 37).
  double confident_weight = 16.0;
  double changed_ratio = 2.0 / 3.0;  // the brighter at least 3x the darker
  double unchanged_share = 0.04;
  double unchanged_bias = 0.005;
  // JPEG frames (add_encoded) are first glanced at: decoded at 1/8 of their size and compared
  // with the map averaged over blocks of the glance's pixel size, at the orientation the drift
  // model predicts, by the test above with `glance_share` for unchanged_share: at that scale the
  // two resamplings differ by 2-4 % of sum |frame - map| in a textured view of an unchanged room
  // (measured on venice), while a lamp switched on moves the bias by far more than
  // unchanged_bias. A frame that sees nothing new and agrees is unchanged (FrameResult::glanced)
  // without its full decode, alignment, exposure estimate and sampling. Needs a cube map whose
  // face the block size divides (the capture's layout).
  bool glance = true;
  double glance_share = 0.08;
  // Other devices' frames (add_device(), issue 49 §1).
  RegistrationOptions registration;
};

// What one frame carries besides its pixels (common/, shared with the client and the wire).
using FrameInfo = arlight::FrameInfo;

struct FrameResult {
  bool used = false;
  std::string skipped_reason;          // set when !used
  glm::dquat orientation{1, 0, 0, 0};  // the orientation the frame was accumulated with
  bool aligned = false;                // the feature alignment produced this frame's correction
  int align_inliers = 0;
  std::string align_note;     // why the alignment was not used, when it was tried
  double correction_deg = 0;  // angle between the sensor and the used orientation
  std::size_t texels_changed = 0;
  // Used, but it agreed with the map (CaptureOptions::unchanged_share): not merged, the map and
  // the SH are as they were. `change` and `bias`: how it differed (the shares the test reads),
  // merged or not; 0 where nothing it saw was measured well before.
  bool unchanged = false;
  // Found unchanged by the glance (CaptureOptions::glance) alone: its whole time is decode_ms.
  bool glanced = false;
  double change = 0, bias = 0;
  double exposure_gain = 0;         // the exposure x gain the frame was accumulated with
  bool exposure_estimated = false;  // estimate_exposure: measured from this frame's overlap
  int exposure_samples = 0;         // the overlapping samples that measurement had
  // Lights this exposure cannot see (issue 16 §4): the fraction of the frame that is clipped
  // where the map holds no unclipped measurement yet, and the largest radiance clipping has
  // proved there (at this frame's exposure or an earlier one). 0 when nothing is clipped.
  double clipped_unmeasured = 0;
  double clipped_floor = 0;
  // Issue 49 §1: frames of a device not registered with the map yet are not merged (used =
  // false, skipped_reason says why) but wait; `registered` says whether the frame's device is
  // as of this frame, and `waiting_merged` how many waiting frames were merged with this one,
  // the frame that registered it (texels_changed counts theirs too).
  bool registered = true;
  int waiting_merged = 0;
  double decode_ms = 0, linearize_ms = 0, align_ms = 0, exposure_ms = 0, project_ms = 0, sh_ms = 0;
  double total_ms() const {
    return decode_ms + linearize_ms + align_ms + exposure_ms + project_ms + sh_ms;
  }
};

// Where another device's frames sit on the map (issue 49 §1): its sensor orientation turned by
// `offset` (world = offset * sensor), its radiance times `radiance_scale` in the map's units.
struct DeviceRegistration {
  bool registered = false;
  glm::dquat offset{1, 0, 0, 0};
  double radiance_scale = 1.0;
  std::size_t waiting = 0;  // frames kept until it registers
};

// The accumulators of a session (what a checkpoint has to keep), in `layout`'s texel order.
struct Accumulators {
  std::vector<float> weighted_radiance;  // sum(w * L), 3 floats per texel
  std::vector<float> weight;             // sum(w), 1 float per texel
};

class CaptureSession {
 public:
  // Throws std::invalid_argument for unusable intrinsics or options.
  CaptureSession(const CameraIntrinsics& camera, CameraResponse response,
                 CaptureOptions options = {});
  ~CaptureSession();
  CaptureSession(CaptureSession&&) noexcept;
  CaptureSession& operator=(CaptureSession&&) noexcept;

  // Decodes a JPEG and adds it. Never throws for bad input: a frame that cannot be used comes
  // back with used = false and the reason. The JPEG is of the camera's size, or of that size
  // divided by a power of two up to frame_reduction() (the same camera's frame, reduced).
  // `device`: whose camera took it (0, the session's own, or one add_device() returned);
  // std::invalid_argument for another number.
  FrameResult add_encoded(std::span<const std::uint8_t> bytes, const FrameInfo& info,
                          int device = 0);
  // Adds an 8-bit BGR image (OpenCV's channel order) of the camera's size, or reduced as above.
  FrameResult add_image(const cv::Mat& bgr8, const FrameInfo& info, int device = 0);
  // How much smaller than the camera's size (each side, a power of two, 1..8) frames may come
  // and lose nothing: the map's texels and the alignment's resolution need no more pixels.
  // (issue 37 §1: what arlightd advises clients to send; 640x480 into arlightd's map: 4.)
  int frame_reduction(int device = 0) const;

  // Two phones, one room (issue 49 §1): another device capturing into this map, with its own
  // camera, response and exposure (`estimate_exposure`: it cannot report it). Its orientation
  // sensor shares gravity with the map's but not heading, and its camera's sensitivity is its
  // own: its first frames are registered against the map (RegistrationOptions) and wait until
  // they are; from then its heading drift is followed like the session camera's. Its
  // sensitivity is measured from the overlap of the frame that registers it and the next few,
  // then kept (an unknown exposure is estimated frame by frame, as the session camera's). Its
  // frames are not glanced at (CaptureOptions::glance). Returns its device number (1, 2, ...).
  // Throws std::invalid_argument for unusable intrinsics.
  int add_device(const CameraIntrinsics& camera, CameraResponse response, bool estimate_exposure);
  // A device's camera with refined optics (a browser's focal length) or exposure reporting;
  // the map, its registration and its drift stay.
  void set_device_camera(int device, const CameraIntrinsics& camera, bool estimate_exposure);
  int device_count() const;
  DeviceRegistration registration(int device) const;
  // A registration as a checkpoint kept it: the device is registered at `offset`.
  // std::invalid_argument for device 0, a rotation that is not a unit one or a scale <= 0.
  void restore_registration(int device, const glm::dquat& offset, double radiance_scale);

  const EnvLayout& layout() const;
  const CameraIntrinsics& camera(int device = 0) const;
  const CameraResponse& response(int device = 0) const;
  const CaptureOptions& options() const;

  // The captured environment: sum(w * L) / sum(w) where seen, the options' fill elsewhere.
  EnvMap environment() const;
  // environment() reduced to `reduced` (arlightd's previews, issue 16 §3), with the share of
  // each of its texels that was measured rather than estimated. A cube layout whose face
  // divides the capture's: each texel the solid-angle-weighted mean of the measured radiance of
  // the texels it covers and of the fill's estimate at its centre for their unseen share (the
  // fill evaluated once per reduced texel: ~1 ms at face 192 -> 64, where environment() takes
  // ~12). Any other layout: reduce(environment(), reduced) and measured_share().
  struct Reduced {
    EnvMap env;
    std::vector<float> measured;  // per texel of `reduced`, row-major, in [0, 1]
  };
  Reduced reduced_environment(const EnvLayout& reduced) const;
  // sum(w * L) / sum(w); texels never seen are 0.
  EnvMap measured_environment() const;
  // sum(w) per texel as a one-channel image in the layout (0 = never seen).
  std::vector<float> weights() const;
  // Fraction of the sphere's solid angle seen by at least one frame.
  double coverage() const;
  // Fraction of the sphere's solid angle whose radiance is estimated rather than measured:
  // 1 - coverage() while filling, 0 with Fill::None or before the first frame.
  double estimated_fraction() const;
  // SH coefficients of environment(): those of measured_environment(), kept current
  // incrementally, plus the fill's over the unseen part (refitted when the map changed, on
  // the first call after it: about 1-2 ms at 512x512).
  const ShCoeffs& sh() const;
  const ShCoeffs& measured_sh() const;
  // How far the light may be off per normal given what is unseen, and the view that would cut
  // that most (arlight/capture/uncertainty.hpp): from the fill's model, refitted as sh() is
  // (after options.fill_refit_* frames or coverage). Everything unknown with Fill::None.
  const LightUncertainty& uncertainty() const;

  std::size_t frames_added() const;  // frames offered
  std::size_t frames_used() const;
  // How many times the fill's model has been fitted (options.fill_refit_*): for benchmarks.
  std::size_t fill_fits() const;

  // The state to checkpoint, and a session restored from it (same camera, layout, order).
  Accumulators accumulators() const;
  void restore(const Accumulators& acc);  // throws std::invalid_argument on a size mismatch

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// The layout arlightd captures into for a map of angle-map resolution N (issue 16 §2): a cube
// map with about as many texels on the sphere (face 3N/8, at least 8: 221,184 texels for
// N = 512 against the angle map's 206,880). Its texels' solid angles vary 5.2x where an angle
// map's vary ~17x (tiny around the back pole), so a frame costs about the same wherever the
// camera looks (BM_CaptureByDirection: max/min 1.4 against 4.4).
EnvLayout capture_layout_for(int n);

// Accumulators of one layout carried over to another (an old checkpoint's angle map into the
// cube map, say): every texel of `to` takes the sums of the texel of `from` its direction falls
// in. Throws std::invalid_argument when `acc` does not fit `from`.
Accumulators convert_accumulators(const Accumulators& acc, const EnvLayout& from,
                                  const EnvLayout& to);

// The share of each texel of `reduced` that was measured (seen by a frame) rather than estimated
// by the fill, from a capture's weights() in `layout` (arlight::reduce of the seen mask).
// Throws std::invalid_argument when the weights do not fit the layout.
std::vector<float> measured_share(const EnvLayout& layout, std::span<const float> weights,
                                  const EnvLayout& reduced);

// Why a frame's metadata cannot be used, or empty when it can (exposure and gain positive and
// finite, orientation a finite unit quaternion within 1e-3).
std::string check_frame_info(const FrameInfo& info);

}  // namespace arlight::capture
