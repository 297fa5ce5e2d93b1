// One frame's path through a capture session (thesis ch. 3): alignment (Kán's), the samples a
// frame gives the map's texels, their merge and the live SH, clipping for the exposure advice,
// the glance, and a device's add(). Part of CaptureSession (capture_impl.hpp).
#include <algorithm>
#include <cmath>
#include <future>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "capture_impl.hpp"

namespace arlight::capture {

glm::dquat CaptureSession::Impl::align(Device& d, const cv::Mat& bgr8, const FrameInfo& info,
                                       const glm::dquat& sensor, FrameResult& result) {
  // An alignment measured in the background from an earlier frame is applied first, at this
  // frame whatever the timing, so results do not depend on thread scheduling.
  if (d.pending_alignment.valid()) apply_alignment(d, d.pending_alignment.get(), result);
  const glm::dquat predicted = glm::normalize(d.drift.predict(info.timestamp) * sensor);
  if (!(covered_solid_angle > 0.0)) return predicted;  // nothing captured yet to align with
  if (++d.frames_since_align < options.align_every) return predicted;
  d.frames_since_align = 0;
  AlignmentMeasurement m;
  m.predicted = predicted, m.sensor = sensor, m.timestamp = info.timestamp;
  d.align_view->render({options.layout, weighted_radiance, weight}, predicted,
                       info.exposure * info.gain, m.rendered, m.mask);
  if (cv::countNonZero(m.mask) < int(m.mask.total() / 5)) {
    result.align_note = "less than 20 % of the view captured before";
    return predicted;
  }
  // The frame at the alignment resolution, blurred about as much as the map's two
  // resamplings (frame -> texels -> view) blur the rendering, so corners sit alike in both.
  const CameraIntrinsics& ak = d.align_camera.intrinsics();
  cv::Mat gray;
  cv::cvtColor(bgr8, gray, cv::COLOR_BGR2GRAY);
  if (gray.cols == ak.width && gray.rows == ak.height)
    m.frame = gray;
  else
    cv::resize(gray, m.frame, cv::Size(ak.width, ak.height), 0, 0, cv::INTER_AREA);
  const double blur = 0.5 * texel_angle(*table) * ak.fx;  // half a texel, in pixels
  cv::GaussianBlur(m.frame, m.frame, cv::Size(0, 0), std::max(0.5, blur));
  const double radius = glm::radians(options.align_max_step_deg) * ak.fx;
  // The features and the fit need nothing of the session but these copies.
  auto measure = [m = std::move(m), camera = d.align_camera, radius,
                  min_inliers = options.align_min_inliers]() mutable {
    m.fit = align_to_rendered(m.frame, m.rendered, m.mask, camera, min_inliers, radius);
    m.rendered.release(), m.mask.release(), m.frame.release();
    return std::move(m);
  };
  if (options.align_async) {
    d.pending_alignment = std::async(std::launch::async, std::move(measure));
    result.align_note = "measured in the background, applied at the next frame";
    return predicted;
  }
  apply_alignment(d, measure(), result);
  return glm::normalize(d.drift.offset() * sensor);
}

void CaptureSession::Impl::apply_alignment(Device& d, const AlignmentMeasurement& m,
                                           FrameResult& result) {
  result.align_inliers = m.fit.inliers;
  if (!m.fit.ok) {
    result.align_note = m.fit.why;
    return;
  }
  const glm::dquat correction = glm::quat_cast(m.fit.rotation);  // camera frame
  const double step = angle_deg(correction, glm::dquat(1, 0, 0, 0));
  if (step > options.align_max_step_deg) {  // a jump this large is a mismatch, not drift
    result.align_note = "rejected a " + std::to_string(step) + " degree correction";
    return;
  }
  const glm::dquat measured = glm::normalize(m.predicted * correction);
  d.drift.update(glm::normalize(measured * glm::conjugate(m.sensor)), m.timestamp);
  result.aligned = true;
}

std::optional<double> CaptureSession::Impl::exposure_ratio(const Device& d,
                                                           const LinearFrame& frame,
                                                           const glm::dquat& orientation,
                                                           int& samples) {
  constexpr int kMinSamples = 64;
  ratio_scratch.clear();
  const TileIndex& ti = *tile_index;
  for_each_sample(d, frame, orientation, [&](std::size_t k, float sw, float r, float g, float b) {
    const std::size_t texel = ti.texel[k];
    if (sw < 0.5f || weight[texel] < 1.0f) return;
    const float* acc = &weighted_radiance[3 * texel];
    // A texel that holds only clipping's lower bound (check_clipped's test) is no measure.
    if (const float floor = clip_floor[texel];
        floor > 0.0f && std::max({acc[0], acc[1], acc[2]}) < kMeasuredShare * floor * weight[texel])
      return;
    const float map = luminance(acc[0], acc[1], acc[2]) / weight[texel];
    const float seen = luminance(r, g, b) / sw;
    if (map > 0.0f && seen > 0.0f) ratio_scratch.push_back(seen / map);
  });
  samples = int(ratio_scratch.size());
  if (samples < kMinSamples) return std::nullopt;
  const auto mid = ratio_scratch.begin() + std::ptrdiff_t(ratio_scratch.size() / 2);
  std::nth_element(ratio_scratch.begin(), mid, ratio_scratch.end());
  return double(*mid);
}

void CaptureSession::Impl::merge(const Sample& s, std::size_t texel) {
  float& w = weight[texel];
  float* acc = &weighted_radiance[3 * texel];
  bool replace = !(w > 0.0f);
  if (!replace && s.sw >= kWellMeasured && w >= kWellMeasured) {
    const float seen = luminance(s.r, s.g, s.b) / s.sw;
    const float held = luminance(acc[0], acc[1], acc[2]) / w;
    replace = std::abs(seen - held) > float(options.changed_ratio) * std::max(seen, held);
  }
  // Above the confident weight the old sums are scaled so the total stays there: an
  // exponential moving average with the sample's share sw / confident_weight.
  const float cap = float(options.confident_weight);
  const float keep = replace ? 0.0f : w + s.sw > cap ? std::max(0.0f, cap - s.sw) / w : 1.0f;
  acc[0] = keep * acc[0] + s.r, acc[1] = keep * acc[1] + s.g, acc[2] = keep * acc[2] + s.b;
  w = keep * w + s.sw;
}

void CaptureSession::Impl::project(const Device& d, const LinearFrame& frame,
                                   const glm::dquat& orientation, FrameResult& result) {
  const auto t0 = Clock::now();
  const TileIndex& ti = *tile_index;
  std::vector<Sample>& samples = samples_scratch;
  samples.clear();
  // The frame against the map where both are measured well (kWellMeasured), luminance x solid
  // angle: sum |seen - held|, sum (seen - held), sum held.
  double differ = 0.0, bias = 0.0, held_sum = 0.0;
  bool sees_new = false;
  for_each_sample(d, frame, orientation, [&](std::size_t k, float sw, float r, float g, float b) {
    const std::size_t texel = ti.texel[k];
    samples.push_back({std::uint32_t(k), sw, r, g, b});
    const float w = weight[texel];
    sees_new = sees_new || !(w > 0.0f);
    if (sw < kWellMeasured || w < kWellMeasured) return;
    const float* acc = &weighted_radiance[3 * texel];
    const double seen = luminance(r, g, b) / sw, held = luminance(acc[0], acc[1], acc[2]) / w;
    differ += std::abs(seen - held) * ti.solid_angle[k];
    bias += (seen - held) * ti.solid_angle[k];
    held_sum += held * ti.solid_angle[k];
  });
  if (held_sum > 0.0) result.change = differ / held_sum, result.bias = bias / held_sum;
  if (!sees_new && held_sum > 0.0 && result.change < options.unchanged_share &&
      std::abs(result.bias) < options.unchanged_bias) {
    result.unchanged = true;
    result.project_ms = ms_since(t0);
    return;
  }
  std::vector<glm::dvec3>&changed_dirs = sh_dirs, &changed_values = sh_values;
  changed_dirs.clear(), changed_values.clear(), newly_seen.clear();
  double newly_seen_omega = 0.0;
  // Only the session's own camera glances (contributors take the full path: add_device()).
  std::optional<Glancer>& glancer = devices.front()->glancer;
  for (const Sample& m : samples) {
    const std::size_t texel = ti.texel[m.k];
    const glm::vec3 before = texel_radiance(texel);
    if (!(weight[texel] > 0.0f)) {
      covered_solid_angle += ti.solid_angle[m.k], newly_seen_omega += ti.solid_angle[m.k];
      newly_seen.push_back(std::uint32_t(texel));
    }
    merge(m, texel);
    if (glancer) glancer->touch(texel);
    const glm::vec3 delta = texel_radiance(texel) - before;
    if (delta != glm::vec3(0.0f)) {
      changed_dirs.emplace_back(ti.dir_x[m.k], ti.dir_y[m.k], ti.dir_z[m.k]);
      changed_values.push_back(glm::dvec3(delta) * ti.solid_angle[m.k]);
    }
  }
  result.texels_changed = changed_dirs.size();
  result.project_ms = ms_since(t0);
  // Live SH: only the change of the texels this frame touched is projected (eq. 2.29 is
  // linear in L), so the coefficients equal a full projection of the current map.
  const auto t1 = Clock::now();
  sh_accumulate(sh, changed_dirs, changed_values);
  if (!changed_dirs.empty() || !newly_seen.empty()) follow_unseen(newly_seen_omega);
  result.sh_ms = ms_since(t1);
}

void CaptureSession::Impl::check_clipped(const Device& d, const LinearFrame& frame,
                                         const glm::dquat& orientation, double exposure_gain,
                                         FrameResult& result) {
  if (frame.clipped_blocks == 0) return;
  ++clipped_frames;
  // A quarter clipped already hides most of a small lamp's power; 0.5 left lab's lamp edges
  // out (3.3 % irradiance error against 2.6 %, TheAdviceLoopCapturesLabsLampsWithinThreePercent).
  constexpr float kMostlyClipped = 0.25f;
  const float floor_here = clip_level(d.response) / float(exposure_gain);
  const EnvLayout& layout = options.layout;
  std::size_t unmeasured = 0;
  float brightest = 0.0f;
  for (int by = 0; by < frame.height; ++by)
    for (int bx = 0; bx < frame.width; ++bx) {
      if (frame.clipped[std::size_t(by) * frame.width + bx] < kMostlyClipped) continue;
      // The block's centre in full-resolution pixels.
      const glm::dvec2 px(bx * d.factor + 0.5 * (d.factor - 1),
                          by * d.factor + 0.5 * (d.factor - 1));
      const glm::ivec2 t = layout.dir_to_texel(orientation * d.pinhole.unproject(px));
      const std::size_t texel = std::size_t(t.y) * layout.width() + std::size_t(t.x);
      float& floor = clip_floor[texel];
      floor = std::max(floor, floor_here);
      const glm::vec3 l = texel_radiance(texel);
      if (std::max({l.x, l.y, l.z}) >= kMeasuredShare * floor) continue;
      ++unmeasured;
      brightest = std::max(brightest, floor);
    }
  result.clipped_unmeasured = double(unmeasured) / double(frame.width * frame.height);
  result.clipped_floor = brightest;
}

std::optional<FrameResult> CaptureSession::Impl::glance(Device& d,
                                                        std::span<const std::uint8_t> bytes,
                                                        const FrameInfo& info) {
  if (!d.glancer || !d.registered || !(covered_solid_angle > 0.0) ||
      !check_frame_info(info).empty())
    return std::nullopt;
  const auto t0 = Clock::now();
  const double exposure_gain = map_exposure_gain(d, info);
  const glm::dquat sensor = glm::normalize(d.base * glm::normalize(info.orientation));
  const glm::dquat predicted =
      options.align ? glm::normalize(d.drift.predict(info.timestamp) * sensor) : sensor;
  const auto v =
      d.glancer->look(bytes, d.response, exposure_gain, predicted, weighted_radiance, weight);
  // At least a quarter of the glance image compared (the rest: border, clipped, black).
  if (!v || v->sees_new || v->clipped_unmeasured || v->pixels < v->image_pixels / 4 ||
      !(v->change < options.glance_share) || !(std::abs(v->bias) < options.unchanged_bias))
    return std::nullopt;
  FrameResult result;
  result.used = result.unchanged = result.glanced = true;
  result.orientation = predicted;
  result.correction_deg = angle_deg(predicted, sensor);
  result.change = v->change, result.bias = v->bias;
  result.exposure_gain = exposure_gain;
  result.decode_ms = ms_since(t0);
  ++used;
  return result;
}

FrameResult CaptureSession::Impl::add(Device& d, const cv::Mat& bgr8, const FrameInfo& info,
                                      FrameResult result, int scale) {
  if (std::string why = check_frame_info(info); !why.empty()) {
    result.skipped_reason = why;
    return result;
  }
  if (bgr8.type() != CV_8UC3) {
    result.skipped_reason = "image is not 8-bit, 3-channel";
    return result;
  }
  const int want_w = (d.camera.width + scale - 1) / scale,
            want_h = (d.camera.height + scale - 1) / scale;
  if (bgr8.cols != want_w || bgr8.rows != want_h) {
    result.skipped_reason = "image is " + size_text(bgr8.cols * scale, bgr8.rows * scale) +
                            ", the camera's intrinsics say " +
                            size_text(d.camera.width, d.camera.height);
    return result;
  }
  // Unknown exposure: linearised at the last frame's estimate, corrected below from the
  // overlap with the map; the first frame's reported value sets the map's scale.
  FrameInfo used_info = info;
  used_info.exposure = map_exposure_gain(d, info), used_info.gain = 1.0;
  double exposure_gain = used_info.exposure;
  auto t0 = Clock::now();
  LinearFrame frame = linearize(bgr8, d.response, exposure_gain, d.factor / scale);
  result.linearize_ms = ms_since(t0);
  const glm::dquat sensor = glm::normalize(d.base * glm::normalize(info.orientation));
  if (!d.registered) return register_or_wait(d, std::move(frame), sensor, exposure_gain, result);
  t0 = Clock::now();
  result.orientation = options.align ? align(d, bgr8, used_info, sensor, result) : sensor;
  result.align_ms = ms_since(t0);
  result.correction_deg = angle_deg(result.orientation, sensor);
  exposure_gain = match_exposure(d, frame, result.orientation, exposure_gain, false, result);
  result.exposure_gain = exposure_gain;
  project(d, frame, result.orientation, result);
  check_clipped(d, frame, result.orientation, exposure_gain, result);
  result.used = true;
  ++used;
  return result;
}

}  // namespace arlight::capture
